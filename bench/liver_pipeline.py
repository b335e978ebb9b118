#!/usr/bin/python3
"""Runs `cvtmesh mesh` on the liver (or any image) and prints the per-stage table the issues ask
for: wall time, peak memory, point counts, Lloyd iterations and time per iteration, quality.

Usage: bench/liver_pipeline.py [IMAGE] [-- extra cvtmesh mesh options]
"""
import json
import os
import subprocess
import sys
import tempfile

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
args = sys.argv[1:]
extra = []
if "--" in args:
    extra = args[args.index("--") + 1:]
    args = args[: args.index("--")]
image = args[0] if args else os.path.join(root, "data", "liver.inr.gz")
cvtmesh = os.path.join(root, "build", "app", "cvtmesh")

with tempfile.TemporaryDirectory() as tmp:
    report_path = os.path.join(tmp, "report.json")
    cmd = [cvtmesh, "mesh", image, "-o", os.path.join(tmp, "mesh.vtu"), "--report", report_path,
           "-q", "--evaluate", *extra]
    subprocess.run(cmd, check=True)
    r = json.load(open(report_path))

print(f"image: {image}   threads: {r['parameters']['threads'] or os.cpu_count()}")
print(f"{'stage':<20}{'wall s':>9}{'peak RSS MB':>13}")
total = 0.0
for s in r["stages"]:
    total += s["wall_s"]
    print(f"{s['name']:<20}{s['wall_s']:>9.3f}{s['peak_rss_mb']:>13.0f}")
print(f"{'total':<20}{total:>9.3f}{r['peak_rss_mb']:>13.0f}")
pre = r.get("preprocess", {})
for s in pre.get("steps", []):
    print(f"  stage 1: {s['name']:<22}{s['wall_s']:>8.3f} s")
c = r["counts"]
print("counts: " + ", ".join(f"{k} {v}" for k, v in c.items()))
lloyd = r.get("lloyd")
if lloyd:
    its = lloyd["iterations"]
    per = [i["wall_s"] for i in its]
    print(f"Lloyd: {len(its)} iterations, converged {lloyd['converged']}, sites {lloyd['sites']}, "
          f"time per iteration mean {sum(per) / len(per) * 1000:.1f} ms (max {max(per) * 1000:.1f} ms), "
          f"final mean displacement {its[-1]['displacement_mean_mm']:.4f} mm")
q = r.get("quality")
if q:
    for key, m in q["measures"].items():
        b = m["bins_percent"]
        print(f"  {key:<18} bins % {b[0]:6.2f} {b[1]:6.2f} {b[2]:6.2f}")
    d = q["dihedral_deg"]
    print(f"  dihedral min {d['min']:.2f} max {d['max']:.2f}; valid {q['validity']['valid']}")
f = r.get("fidelity")
if f:
    print(f"  fidelity: volume error {f['volume_error_percent']:.2f} %, Hausdorff {f['hausdorff_mm']:.2f} mm, "
          f"mean {f['mean_mm']:.2f} mm, p95 {f['p95_mm']:.2f} mm")
