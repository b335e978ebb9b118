#!/usr/bin/python3
"""Ctrl-C during `cvtmesh mesh` on the liver (scripts/fetch-data), at several moments and stages.

Usage: test_cancel.py CVTMESH SOURCE_DIR [TEST NAMES]   (ctest, Debian's /usr/bin/python3)
"""
import os
import queue
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest

CVTMESH = sys.argv[1] if len(sys.argv) > 1 else "build/app/cvtmesh"
SOURCE = sys.argv[2] if len(sys.argv) > 2 else "."
LIVER = os.path.join(SOURCE, "data", "liver.inr.gz")


class CtrlC(unittest.TestCase):
    """SIGINT during `cvtmesh mesh` on the liver, at several moments and stages: the run stops
    within a second with exit 130 and one line saying so, and leaves no file behind."""

    def interrupt(self, when, *extra):
        """when: seconds after the start, or the progress line after which to interrupt."""
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "liver.vtu")
            p = subprocess.Popen([CVTMESH, "mesh", LIVER, "-o", out, "--report",
                                  os.path.join(tmp, "r.json"), *extra],
                                 stderr=subprocess.PIPE, text=True)
            lines = queue.Queue()
            reader = threading.Thread(target=lambda: [lines.put(l) for l in p.stderr], daemon=True)
            reader.start()
            seen = []
            try:
                if isinstance(when, float):
                    time.sleep(when)
                else:
                    while not any(l.startswith("cvtmesh: " + when) for l in seen):
                        seen.append(lines.get(timeout=600))
                self.assertIsNone(p.poll(), "finished before the interrupt:\n" + "".join(seen))
                p.send_signal(signal.SIGINT)
                sent = time.monotonic()
                p.wait(timeout=60)
                took = time.monotonic() - sent
            finally:
                if p.poll() is None:
                    p.kill()
                    p.wait()
            reader.join(timeout=10)
            p.stderr.close()
            while not lines.empty():
                seen.append(lines.get())
            self.assertLess(took, 1.0, f"stopped {took:.2f} s after the signal")
            self.assertEqual(os.listdir(tmp), [], "output left behind")
            if p.returncode == -signal.SIGINT and not seen:
                return  # still starting up (loading libraries): the default action, as it should
            self.assertEqual(p.returncode, 130, "".join(seen))
            self.assertEqual(seen[-1], "cvtmesh: cancelled; nothing was written\n")

    def test_early(self):
        self.interrupt(0.3)

    def test_reading(self):
        self.interrupt(1.0)

    def test_stage_one(self):
        self.interrupt("local feature size")

    def test_surface_sampling(self):
        self.interrupt("surface sampling")

    def test_lloyd(self):
        self.interrupt("Lloyd iteration 3")

    def test_delaunay(self):
        self.interrupt("Delaunay")

    def test_fidelity(self):
        self.interrupt("fidelity")

    def test_optimisation(self):
        self.interrupt("optimisation pass", "--optimize", "default")


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]] + sys.argv[3:], verbosity=2)
