#!/usr/bin/python3
"""The same anatomy gives about the same mesh at any scan resolution: the liver and a sphere
phantom meshed as they are and resampled to half the spacing in every axis (nearest neighbour,
8x the voxels, the resampling of bench/sweep) with default parameters.

Usage: test_resolution.py CVTMESH SOURCE_DIR   (ctest, Release only: 8x the liver's voxels)
"""
import importlib.machinery
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import unittest

CVTMESH = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build/app/cvtmesh")
SOURCE = sys.argv[2] if len(sys.argv) > 2 else "."
LIVER = os.path.join(SOURCE, "data", "liver.inr.gz")
PHANTOM = os.environ.get("CVTMESH_PHANTOM") or os.path.join(
    os.path.dirname(os.path.dirname(CVTMESH)), "tests", "phantoms", "cvtmesh-phantom")

# bench/sweep resamples with cvtmesh's own reading of the geometry (`cvtmesh info`).
os.environ["CVTMESH_BUILD_DIR"] = os.path.dirname(os.path.dirname(CVTMESH))
sys.dont_write_bytecode = True
_loader = importlib.machinery.SourceFileLoader("sweep", os.path.join(SOURCE, "bench", "sweep"))
sweep = importlib.util.module_from_spec(importlib.util.spec_from_loader("sweep", _loader))
_loader.exec_module(sweep)


def mesh(image, work, name):
    out, report = os.path.join(work, name + ".mesh"), os.path.join(work, name + ".json")
    r = subprocess.run([CVTMESH, "mesh", image, "-o", out, "--report", report, "--evaluate",
                        "-q"], capture_output=True, text=True, timeout=1200)
    if r.returncode != 0:
        raise AssertionError(f"cvtmesh mesh {image}: {r.stderr}")
    with open(report) as f:
        return json.load(f)


class SameAnatomy(unittest.TestCase):
    def compare(self, image, work, name):
        fine_image, meta = sweep.resampled(image, 2, work)
        coarse, fine = mesh(image, work, name), mesh(fine_image, work, name + "_fine")
        fine_voxel = max(meta["check"]["spacing"])
        n0, n1 = coarse["counts"]["vertices"], fine["counts"]["vertices"]
        print(f"{name}: {n0} -> {n1} vertices; mean {coarse['fidelity']['mean_mm']:.3f} -> "
              f"{fine['fidelity']['mean_mm']:.3f} mm; p95 {coarse['fidelity']['p95_mm']:.3f} -> "
              f"{fine['fidelity']['p95_mm']:.3f} mm; Hausdorff {coarse['fidelity']['hausdorff_mm']:.2f} -> "
              f"{fine['fidelity']['hausdorff_mm']:.2f} mm", file=sys.stderr)
        self.assertLess(abs(n1 - n0) / n0, 0.15, f"{name}: {n0} vertices, {n1} at half spacing")
        v0, v1 = (r["quality"]["validity"] for r in (coarse, fine))
        self.assertTrue(v1["boundary_closed_manifold"])

        self.assertEqual(v0["euler_characteristic"], v1["euler_characteristic"], name)
        self.assertEqual(v0["boundary_components"], v1["boundary_components"], name)
        for key in ("mean_mm", "p95_mm"):
            self.assertLess(abs(fine["fidelity"][key] - coarse["fidelity"][key]), fine_voxel,
                            f"{name}: {key}")
        # The object's scale does not depend on the voxels (splitting each into 2^3 leaves it).
        self.assertAlmostEqual(coarse["preprocess"]["volume_to_area_mm"],
                               fine["preprocess"]["volume_to_area_mm"], places=5)
        return coarse, fine

    def test_liver(self):
        self.assertTrue(os.path.exists(LIVER), "run scripts/fetch-data first")
        with tempfile.TemporaryDirectory() as work:
            coarse, fine = self.compare(LIVER, work, "liver")
            # The liver's own voxels still set its sizes; at half the spacing the anatomy does.
            self.assertAlmostEqual(coarse["preprocess"]["sizing_unit_mm"], 1.3333, places=3)
            self.assertGreater(fine["preprocess"]["sizing_unit_mm"], 0.6667 * 1.5)

    def test_sphere(self):
        with tempfile.TemporaryDirectory() as work:
            image = os.path.join(work, "sphere.nii.gz")
            subprocess.run([PHANTOM, "sphere", "-o", image, "--size", "30", "--spacing", "0.6",
                            "0.6", "0.6"], check=True, timeout=120)
            coarse, fine = self.compare(image, work, "sphere")
            # A ball large against its voxels: the anatomy sets λ and lfs max at both.
            for key in ("sizing_unit_mm", "medial_min_separation_mm", "lfs_max_mm"):
                self.assertAlmostEqual(coarse["preprocess"][key], fine["preprocess"][key],
                                       places=5, msg=key)
            self.assertGreater(coarse["preprocess"]["sizing_unit_mm"], 0.6)
            # Stage 6 reaches its target at both resolutions: at the finer one, flat caps on the
            # resampled staircase need their ridge split. (The liver at half its spacing does
            # not reach it yet.)
            for r in (coarse, fine):
                self.assertGreaterEqual(r["quality"]["dihedral_deg"]["min"], 15.0 - 1e-9)


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
