#!/usr/bin/python3
"""End-to-end checks of the cvtmesh command line: the liver's `info` figures and bad inputs.

Usage: test_cli.py CVTMESH SOURCE_DIR   (run by ctest with Debian's /usr/bin/python3)
"""
import gzip
import json
import os
import subprocess
import sys
import tempfile
import unittest

CVTMESH = sys.argv[1] if len(sys.argv) > 1 else "build/app/cvtmesh"
SOURCE = sys.argv[2] if len(sys.argv) > 2 else "."
LIVER = os.path.join(SOURCE, "data", "liver.inr.gz")
# The phantom tool (tests/phantoms): ctest names it; by hand, its place in the build folder.
PHANTOM = os.environ.get("CVTMESH_PHANTOM") or os.path.join(
    os.path.dirname(os.path.dirname(os.path.abspath(CVTMESH))), "tests", "phantoms",
    "cvtmesh-phantom")


def run(*args, env=None):
    return subprocess.run([CVTMESH, *args], capture_output=True, text=True, timeout=600,
                          env=None if env is None else {**os.environ, **env})


class Info(unittest.TestCase):
    def test_liver_json(self):
        self.assertTrue(os.path.exists(LIVER), "run scripts/fetch-data first")
        r = run("info", LIVER, "--json")
        self.assertEqual(r.returncode, 0, r.stderr)
        info = json.loads(r.stdout)
        self.assertEqual(info["dims"], [438, 353, 165])
        for got, want in zip(info["spacing"], [0.617188, 0.617188, 1.33333]):
            self.assertAlmostEqual(got, want, places=5)
        counts = {h["label"]: h["count"] for h in info["labels"]}
        self.assertEqual(counts, {0: 22019024, 255: 3160496, 127: 314086, 85: 17702, 84: 2})

    def test_liver_text(self):
        r = run("info", LIVER)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("438 x 353 x 165", r.stdout)
        self.assertIn("3160496", r.stdout)


class MeshLiver(unittest.TestCase):
    """The real liver end to end with default parameters (issue 4's acceptance figures)."""

    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.TemporaryDirectory()
        cls.mesh = os.path.join(cls.dir.name, "liver.mesh")
        cls.report_path = os.path.join(cls.dir.name, "report.json")
        r = run("mesh", LIVER, "-o", cls.mesh, "--report", cls.report_path, "--threads", "2", "-q",
                "--evaluate")
        assert r.returncode == 0, r.stderr
        with open(cls.report_path) as f:
            cls.report = json.load(f)

    @classmethod
    def tearDownClass(cls):
        cls.dir.cleanup()

    def test_valid_closed_one_component(self):
        v = self.report["quality"]["validity"]
        self.assertTrue(v["valid"])
        self.assertTrue(v["boundary_closed_manifold"])
        self.assertEqual(v["boundary_components"], 1)
        self.assertEqual(v["inverted"], 0)
        self.assertEqual(v["zero_volume"], 0)
        self.assertEqual(v["unreferenced_vertices"], 0)

    def test_fidelity(self):
        f = self.report["fidelity"]
        self.assertLess(abs(f["volume_error_percent"]), 2.0)
        self.assertLess(f["p95_mm"], 1.0)
        self.assertLess(f["hausdorff_mm"], 4.0)

    def test_boundary_has_the_objects_topology(self):
        # The marching-cubes surface of the cleaned object is the reference (the liver's is a
        # torus: a narrow channel runs through it, which fidelity refinement opens).
        f, v = self.report["fidelity"], self.report["quality"]["validity"]
        self.assertEqual(v["euler_characteristic"], f["object_surface_euler"])
        self.assertEqual(v["boundary_components"], f["object_surface_components"])
        rounds = self.report["refinement"]
        self.assertGreaterEqual(len(rounds), 1)
        self.assertGreater(rounds[0]["disagreeing_voxels"], 0)

    def test_fidelity_with_another_seed(self):
        # Seed 3 is the hard case of the liver's narrow channel. Its first mesh has a pit by the
        # channel (an exterior pole exposes an interior sample deep in the object), and the
        # round that fills it leaves a pillar across the channel (a handle more). Refinement
        # returns the mesh with the object's topology, so the pit stays (Hausdorff 5.0 mm),
        # but no mesh is returned with a deeper pit or the wrong topology.
        with tempfile.TemporaryDirectory() as d:
            report = os.path.join(d, "report.json")
            r = run("mesh", LIVER, "-o", os.path.join(d, "liver.mesh"), "--report", report,
                    "--threads", "2", "-q", "--seed", "3", "--optimize", "none", "--evaluate")
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(report) as f:
                rep = json.load(f)
        f, v = rep["fidelity"], rep["quality"]["validity"]
        self.assertEqual(v["euler_characteristic"], f["object_surface_euler"])
        self.assertLess(f["hausdorff_mm"], 5.5)
        self.assertLess(f["p95_mm"], 1.0)
        returned = [r for r in rep["refinement"] if r["returned"]]
        self.assertEqual(len(returned), 1)
        self.assertLessEqual(returned[0]["deep_boundary_samples"], 1)

    def test_table_one_at_least_as_good_as_the_paper(self):
        m = self.report["quality"]["measures"]
        self.assertLessEqual(m["v_over_rmc3"]["bins_percent"][0], 2.59)
        self.assertLessEqual(m["gradient_error"]["bins_percent"][0], 7.66)
        self.assertLessEqual(m["condition_number"]["bins_percent"][0], 6.83)

    def test_report_layout(self):
        r = self.report
        for key in ["parameters", "stages", "lloyd", "counts", "quality", "fidelity"]:
            self.assertIn(key, r)
        for key in ["surface_samples", "interior_samples", "shallow_removed", "exterior_poles",
                    "vertices", "tets"]:
            self.assertGreater(r["counts"][key], 0, key)
        energies = [i["energy"] for i in r["lloyd"]["iterations"]]
        self.assertTrue(all(b <= a for a, b in zip(energies, energies[1:])), energies)

    def test_quality_command_reads_it_back(self):
        r = run("quality", self.mesh, "--json")
        self.assertEqual(r.returncode, 0, r.stderr)
        q = json.loads(r.stdout)
        self.assertEqual(q["tets"], self.report["counts"]["tets"])
        self.assertEqual(q["validity"]["valid"], True)

    def test_same_input_same_bytes(self):
        again = os.path.join(self.dir.name, "again.mesh")
        preset = os.path.join(self.dir.name, "preset.json")
        report = os.path.join(self.dir.name, "again.json")
        r = run("mesh", LIVER, "-o", again, "--threads", "2", "-q", "--save-preset", preset,
                "--report", report)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(self.mesh, "rb") as a, open(again, "rb") as b:
            self.assertTrue(a.read() == b.read(), "two runs gave different meshes")
        # Without --evaluate (this run) the report has quality but no fidelity, and the mesh is
        # the same as with it (the class's run).
        with open(report) as f:
            rep = json.load(f)
        self.assertIn("quality", rep)
        self.assertNotIn("fidelity", rep)
        self.assertNotIn("fidelity", [s["name"] for s in rep["stages"]])
        # The saved preset reproduces the run too, and so does malloc without the huge pages
        # cvtmesh asks it for (the mesh must not depend on where memory lies).
        third = os.path.join(self.dir.name, "third.mesh")
        r = run("mesh", LIVER, "-o", third, "--preset", preset, "-q",
                env={"GLIBC_TUNABLES": "glibc.malloc.hugetlb=0"})
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(self.mesh, "rb") as a, open(third, "rb") as b:
            self.assertTrue(a.read() == b.read(), "the saved preset gave a different mesh")


class Optimize(unittest.TestCase):
    def test_optimize_default_removes_slivers_and_stays_valid(self):
        torus = os.path.join(SOURCE, "assets", "phantom_torus.nii.gz")
        with tempfile.TemporaryDirectory() as tmp:
            out, report = os.path.join(tmp, "t.mesh"), os.path.join(tmp, "r.json")
            r = run("mesh", torus, "-q", "--optimize", "default", "-o", out, "--report", report)
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(report) as f:
                q = json.load(f)["quality"]
            self.assertTrue(q["validity"]["valid"])
            self.assertEqual(q["validity"]["euler_characteristic"], 0)  # still a torus
            self.assertGreaterEqual(q["dihedral_deg"]["min"], 10.0)

    def test_stage6_options_from_the_command_line_and_a_preset(self):
        # --opt-KEY overrides the preset's "optimization" object, which overrides the defaults;
        # the report records what ran.
        torus = os.path.join(SOURCE, "assets", "phantom_torus.nii.gz")
        with tempfile.TemporaryDirectory() as tmp:
            preset, report = os.path.join(tmp, "p.json"), os.path.join(tmp, "r.json")
            with open(preset, "w") as f:
                json.dump({"optimize": "default",
                           "optimization": {"max_passes": 1, "target_dihedral_deg": 12}}, f)
            out = os.path.join(tmp, "t.vtu")
            r = run("mesh", torus, "-q", "--preset", preset, "--opt-target-dihedral-deg", "25",
                    "-o", out, "--report", report)
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(report) as f:
                rep = json.load(f)
            self.assertEqual(rep["parameters"]["optimization"]["max_passes"], 1)
            self.assertEqual(rep["parameters"]["optimization"]["target_dihedral_deg"], 25)
            self.assertEqual(len(rep["optimization"]["passes"]), 2)  # before + one pass
            # Out of range: one line naming the key, no output.
            os.remove(out)
            r = run("mesh", torus, "-q", "--optimize", "default", "--opt-max-passes", "-1",
                    "-o", out)
            self.assertNotEqual(r.returncode, 0)
            self.assertIn("optimization.max_passes", r.stderr)
            self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
            self.assertFalse(os.path.exists(out))


class Skull(unittest.TestCase):
    """The skull CT (iso 2.9): the cranial cavity is as large as the bone, so the default keeps
    it (filling it made a solid head of twice the bone's volume)."""

    def test_keeps_its_cavity(self):
        image = os.path.join(SOURCE, "data", "skull_2.9.inr")
        self.assertTrue(os.path.exists(image), "run scripts/fetch-data first")
        with tempfile.TemporaryDirectory() as tmp:
            mesh, report = os.path.join(tmp, "skull.mesh"), os.path.join(tmp, "r.json")
            r = run("mesh", image, "--iso", "2.9", "-o", mesh, "--report", report, "-q",
                    "--evaluate")
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(report) as f:
                rep = json.load(f)
        pre = rep["preprocess"]
        self.assertEqual((pre["cavities_kept"], pre["cavities_filled"]), (1, 0))
        self.assertGreater(pre["cavity_voxels_kept"], 10000)
        self.assertTrue(rep["quality"]["validity"]["valid"])
        # Against the bone alone (the evaluation's object keeps the cavity too): the volume
        # within a few percent, not doubled, and no place farther off than a voxel.
        fid = rep["fidelity"]
        self.assertLess(abs(fid["volume_error_percent"]), 3.0)
        self.assertLess(fid["hausdorff_mm"], 3.95)  # the largest spacing


class QualityFidelity(unittest.TestCase):
    def test_quality_image_agrees_with_the_run_report(self):
        # A ball with a small enclosed cavity and a far speck, so the clean-up (fill cavities, drop
        # small components) changes the object: `quality --image` must judge against the same
        # cleaned object as the run's own evaluation, with the default clean-up and without it.
        n = 40
        voxels = bytearray(n ** 3)
        for z in range(n):
            for y in range(n):
                for x in range(n):
                    r2 = (x - 22) ** 2 + (y - 22) ** 2 + (z - 22) ** 2
                    speck = max(x, y, z) <= 3 and min(x, y, z) >= 2
                    voxels[x + n * (y + n * z)] = 1 if 4 < r2 <= 144 or speck else 0
        with tempfile.TemporaryDirectory() as tmp:
            image = os.path.join(tmp, "ball.nrrd")
            with open(image, "wb") as f:
                f.write(b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 40 40 40\n"
                        b"spacings: 1 1 1\nencoding: raw\n\n" + bytes(voxels))
            for cleanup in ([], ["--fill-cavities", "false", "--remove-small-components", "false"]):
                mesh, report = os.path.join(tmp, "ball.mesh"), os.path.join(tmp, "r.json")
                r = run("mesh", image, "-q", "-o", mesh, "--report", report, "--evaluate",
                        *cleanup)
                self.assertEqual(r.returncode, 0, r.stderr)
                with open(report) as f:
                    want = json.load(f)["fidelity"]
                r = run("quality", mesh, "--image", image, "--json", *cleanup)
                self.assertEqual(r.returncode, 0, r.stderr)
                got = json.loads(r.stdout)["fidelity"]
                for key in ["object_volume_mm3", "volume_error_percent", "hausdorff_mm",
                            "mean_mm", "p95_mm"]:
                    self.assertAlmostEqual(got[key], want[key], delta=1e-6 * max(1, abs(want[key])),
                                           msg=f"{key} with clean-up {cleanup or 'default'}")


class BadInput(unittest.TestCase):
    """Each bad input: non-zero exit, exactly one line on stderr naming the file, no crash.
    (`mesh` runs with -q so its progress lines do not count.)"""

    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()

    def tearDown(self):
        self.dir.cleanup()

    def path(self, name):
        return os.path.join(self.dir.name, name)

    def assert_one_line_error(self, result, must_contain):
        self.assertNotEqual(result.returncode, 0)
        self.assertLess(result.returncode, 128, "crashed: " + result.stderr)
        lines = result.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, result.stderr)
        self.assertIn(must_contain, lines[0])

    def test_missing_file(self):
        p = self.path("nope.nii.gz")
        self.assert_one_line_error(run("info", p), p)

    def test_unsupported_extension(self):
        p = self.path("image.xyz")
        with open(p, "w") as f:
            f.write("hello")
        self.assert_one_line_error(run("info", p), "unsupported")

    def test_truncated_nii_gz(self):
        # A real image cut in half, written by our own phantom tool.
        good = self.path("torus.nii.gz")
        subprocess.run([PHANTOM, "torus", "-o", good], check=True)
        with open(good, "rb") as f:
            data = f.read()
        bad = self.path("cut.nii.gz")
        with open(bad, "wb") as f:
            f.write(data[: len(data) // 2])
        self.assert_one_line_error(run("info", bad), bad)
        out = self.path("cut.vtu")
        self.assert_one_line_error(run("mesh", bad, "-q", "-o", out), bad)
        self.assertFalse(os.path.exists(out))

    def test_2d_image(self):
        # A 2D NRRD written by hand: 4 x 3 pixels.
        p = self.path("flat.nrrd")
        with open(p, "wb") as f:
            f.write(b"NRRD0004\ntype: uint8\ndimension: 2\nsizes: 4 3\nencoding: raw\n\n")
            f.write(bytes(12))
        self.assert_one_line_error(run("info", p), "2D")

    def test_absurd_dims(self):
        # A header promising 100000^3 voxels must be refused before anything is allocated.
        p = self.path("huge.nhdr")
        with open(p, "w") as f:
            f.write("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 100000 100000 100000\n"
                    "encoding: raw\ndata file: huge.raw\n\n")
        with open(self.path("huge.raw"), "wb") as f:
            f.write(bytes(16))
        self.assert_one_line_error(run("info", p), p)

    def test_empty_label_selection(self):
        out = self.path("liver.vtu")
        self.assert_one_line_error(run("mesh", LIVER, "-q", "--labels", "7", "-o", out), "label 7")
        self.assertFalse(os.path.exists(out))

    def test_bad_parameter(self):
        out = self.path("liver.vtu")
        self.assert_one_line_error(run("mesh", LIVER, "-q", "--r", "1.5", "-o", out), "r: must be in (0, 1)")

    def test_exploding_parameters_are_refused(self):
        out = self.path("liver.vtu")
        r = run("mesh", LIVER, "-q", "--interior-spacing", "0.3", "-o", out)
        self.assert_one_line_error(r, "max_points")
        self.assertFalse(os.path.exists(out))

    def test_memory_limit(self):
        out = self.path("liver.vtu")
        self.assert_one_line_error(run("mesh", LIVER, "-q", "--max-memory", "10", "-o", out),
                                   "are allowed")
        self.assertFalse(os.path.exists(out))

    def test_output_folder_missing(self):
        out = self.path("no/such/folder/liver.vtu")
        self.assert_one_line_error(run("mesh", LIVER, "-q", "-o", out), "does not exist")

    def test_bad_preset(self):
        preset = self.path("p.json")
        with open(preset, "w") as f:
            f.write('{"r": 0.3, "radius": 2}')
        self.assert_one_line_error(run("mesh", LIVER, "-q", "--preset", preset, "-o", self.path("x.vtu")),
                                   "unknown parameter 'radius'")


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]] + sys.argv[3:], verbosity=2)  # extra: test names
