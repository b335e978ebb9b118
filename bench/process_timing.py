"""Whole-process timing for bench/compare and bench/sweep: each run is one command under
/usr/bin/time -v (at nice -15 when root), its wall time the "Elapsed (wall clock)" and its memory
the "Maximum resident set size" that /usr/bin/time reports, and a wait for idle CPUs before it.
"""
import os
import re
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NICE = ["nice", "-n", "-15"] if os.geteuid() == 0 else []


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def cpu_times():
    with open("/proc/stat") as f:
        v = [int(x) for x in f.readline().split()[1:]]
    return sum(v), v[3] + v[4]  # total, idle + iowait


def wait_for_idle_cpu(max_wait_s, max_busy=0.15):
    """Waits (up to max_wait_s) until the CPUs are ≥ 85 % idle over 2 s; returns the busy
    fraction of that last window (other processes' load just before a timed run)."""
    t_end = time.time() + max_wait_s
    while True:
        t0, i0 = cpu_times()
        time.sleep(2)
        t1, i1 = cpu_times()
        busy = 1 - (i1 - i0) / max(1, t1 - t0)
        if busy <= max_busy or time.time() > t_end:
            return busy
        if int(time.time()) % 60 < 2:
            log(f"machine busy ({busy:.0%}), waiting")


def load_average():
    return open("/proc/loadavg").read().split()[:3]


def elapsed_s(text):
    """/usr/bin/time's "h:mm:ss" or "m:ss.cc" in seconds."""
    s = 0.0
    for part in text.split(":"):
        s = 60 * s + float(part)
    return s


def timed_run(cmd, timeout=None, **kw):
    """Runs cmd as a whole process under /usr/bin/time -v at raised priority (so other users'
    builds on a shared machine disturb the timing less). Returns {"out": stdout, "wall_s":
    /usr/bin/time's elapsed wall clock, "wall_s_outer": time.monotonic() around the Popen,
    "cpu_s": user + sys, "peak_rss_mb": maximum resident set size}, or None when it ran out of
    timeout seconds (then its whole process group is ended). Exits on a failed command."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as t:
        t0 = time.monotonic()
        p = subprocess.Popen([*NICE, "/usr/bin/time", "-v", "-o", t.name, *cmd], text=True,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             start_new_session=True, **kw)
        try:
            out, err = p.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.communicate()
            return None
        outer = time.monotonic() - t0
        if p.returncode != 0:
            sys.exit(f"failed ({p.returncode}): {' '.join(cmd)}\n{err[-2000:]}")
        tv = t.read()

    def field(name):
        return re.search(re.escape(name) + r": (\S+)", tv).group(1)

    return {"out": out, "wall_s": elapsed_s(field("Elapsed (wall clock) time (h:mm:ss or m:ss)")),
            "wall_s_outer": outer,
            "cpu_s": float(field("User time (seconds)")) + float(field("System time (seconds)")),
            "peak_rss_mb": int(field("Maximum resident set size (kbytes)")) / 1024}


def shown(path):
    """A path as a user in the repository would type it."""
    path = os.path.abspath(path)
    return os.path.relpath(path, ROOT) if path.startswith(ROOT + os.sep) else path


def commit():
    """The repository's commit, and whether tracked files differ from it."""
    try:
        c = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"],
                           capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", ROOT, "diff", "--quiet", "HEAD"]).returncode != 0
        return c + (" with uncommitted changes" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
