#!/usr/bin/python3
"""The two transforms of a NIfTI header (qform and sform) through `cvtmesh info` and `mesh`.

Images written with nibabel: a ball of radius 8 voxels in a 32³ image, with equal transforms,
disagreeing ones, only a qform, only an sform, and neither. Checks that the warning appears
exactly when the two disagree, that info --json gives both, and that the mesh overlays the
image in the frame chosen: its boundary vertices lie within a voxel of the ball's surface
mapped through that frame's affine.

Usage: test_nifti_frames.py CVTMESH   (run by ctest with Debian's /usr/bin/python3)
"""
import json
import os
import subprocess
import sys
import tempfile
import unittest

import meshio
import nibabel
import numpy as np

CVTMESH = sys.argv[1] if len(sys.argv) > 1 else "build/app/cvtmesh"

SIZE, RADIUS = 32, 8.0
CENTRE = np.array([15.5, 15.5, 15.5])  # voxel index of the ball's centre
ZOOMS = (0.9, 1.1, 1.3)  # mm, the same in both transforms (ITK checks pixdim against them)
LPS_FROM_RAS = np.diag([-1.0, -1.0, 1.0, 1.0])  # cvtmesh writes meshes in ITK's LPS space


def rigid(axis, degrees, offset):
    """An index → RAS affine: a rotation about `axis` (0, 1, 2), ZOOMS, then `offset` (mm)."""
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    a, b = [i for i in range(3) if i != axis]
    rotation = np.eye(3)
    rotation[a, a], rotation[a, b], rotation[b, a], rotation[b, b] = c, -s, s, c
    affine = np.eye(4)
    affine[:3, :3] = rotation @ np.diag(ZOOMS)
    affine[:3, 3] = offset
    return affine


QFORM = rigid(2, 20, [12.0, -30.0, 45.0])
SFORM = rigid(0, 35, [-60.0, 25.0, -10.0])
# Neither code set: the voxel spacing alone, as ITK reads such files (origin 0, LPS axes).
# (nibabel's fallback for them differs: it centres the image and flips x.)
SCALING_LPS = np.diag([*ZOOMS, 1.0])


def write_nifti(path, qform, qform_code, sform, sform_code):
    i, j, k = np.meshgrid(*[np.arange(SIZE)] * 3, indexing="ij")
    ball = ((np.stack([i, j, k], -1) - CENTRE) ** 2).sum(-1) <= RADIUS**2
    image = nibabel.Nifti1Image(ball.astype(np.uint8), None)
    image.header.set_zooms(ZOOMS)
    image.set_qform(qform, code=qform_code)  # code 0 keeps the values, marked as not set
    image.set_sform(sform, code=sform_code)
    nibabel.save(image, path)
    return path


def run(*args):
    return subprocess.run([CVTMESH, *args], capture_output=True, text=True, timeout=600)


def warning_lines(stderr):
    return [line for line in stderr.splitlines() if "warning" in line]


def surface_deviation_voxels(mesh_path, index_to_lps):
    """|distance from the ball's centre| − radius, in voxels, of every boundary vertex mapped
    back to a voxel index through `index_to_lps`."""
    mesh = meshio.read(mesh_path)
    boundary = np.unique(mesh.cells_dict["triangle"])
    points = np.c_[mesh.points[boundary], np.ones(len(boundary))]
    index = (np.linalg.inv(index_to_lps) @ points.T).T[:, :3]
    return np.linalg.norm(index - CENTRE, axis=1) - RADIUS


class NiftiFrames(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.TemporaryDirectory()
        p = lambda name: os.path.join(cls.dir.name, name)
        # name: file, qform, its code, sform, its code
        cases = {
            "equal": ("equal.nii.gz", SFORM, 1, SFORM, 1),
            "disagree": ("disagree.nii.gz", QFORM, 1, SFORM, 2),
            "qform only": ("qonly.nii.gz", QFORM, 1, SFORM, 0),
            "sform only": ("sonly.nii", QFORM, 0, SFORM, 1),
            "neither": ("neither.nii.gz", QFORM, 0, SFORM, 0),
        }
        cls.files = {name: write_nifti(p(c[0]), *c[1:]) for name, c in cases.items()}
        cls.affines = {name: {"qform": c[1], "sform": c[3]} for name, c in cases.items()}
        # Where each file's image is, as cvtmesh's frame rule has it by default (the sform when
        # its code is non-zero, then the qform, then the spacing alone).
        cls.default_frame = {"equal": "sform", "disagree": "sform", "qform only": "qform",
                             "sform only": "sform", "neither": "scaling"}

    @classmethod
    def tearDownClass(cls):
        cls.dir.cleanup()

    def path(self, name):
        return os.path.join(self.dir.name, name)

    def info(self, name_or_path, *options):
        path = self.files.get(name_or_path, name_or_path)
        r = run("info", path, "--json", *options)
        self.assertEqual(r.returncode, 0, r.stderr)
        return json.loads(r.stdout), r.stderr

    def mesh(self, name, *options):
        out = self.path(f"{name.replace(' ', '_')}{len(options)}.mesh")
        report = out + ".json"
        r = run("mesh", self.files[name], "-o", out, "--report", report, "-q", "--threads", "2",
                *options)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(report) as f:
            return out, json.load(f), r.stderr

    def expected_lps(self, name, frame):
        """The index → LPS map of file `name` in `frame` ("qform", "sform" or "scaling")."""
        return SCALING_LPS if frame == "scaling" else LPS_FROM_RAS @ self.affines[name][frame]

    def assert_overlays(self, mesh_path, name, frame):
        deviation = surface_deviation_voxels(mesh_path, self.expected_lps(name, frame))
        self.assertLess(np.abs(deviation).max(), 1.0, f"boundary off the ball in the {frame}")
        self.assertLess(abs(deviation.mean()), 0.5)

    def test_info_gives_both_transforms_as_nibabel_reads_them(self):
        for name, path in self.files.items():
            with self.subTest(name):
                info, _ = self.info(name)
                header = nibabel.load(path).header
                for frame in ("qform", "sform"):
                    affine, code = getattr(header, f"get_{frame}")(coded=True)
                    got = info["nifti"][frame]
                    self.assertEqual(got["code"], int(code))
                    if affine is None:
                        self.assertIsNone(got["matrix"])
                    else:
                        np.testing.assert_allclose(got["matrix"], affine, atol=1e-4)
                self.assertEqual(info["nifti"]["frame"], self.default_frame[name])

    def test_geometry_is_the_frame_chosen_with_fallbacks(self):
        cases = [  # file, --nifti-frame, the frame used
            ("disagree", "sform", "sform"), ("disagree", "qform", "qform"),
            ("qform only", "sform", "qform"), ("qform only", "qform", "qform"),
            ("sform only", "sform", "sform"), ("sform only", "qform", "sform"),
            ("neither", "qform", "scaling"), ("neither", "sform", "scaling"),
        ]
        for name, asked, used in cases:
            with self.subTest(f"{name}, --nifti-frame {asked}"):
                info, _ = self.info(name, "--nifti-frame", asked)
                self.assertEqual(info["nifti"]["frame"], used)
                want = self.expected_lps(name, used)
                np.testing.assert_allclose(info["origin"], want[:3, 3], atol=1e-4)
                direction = np.array(info["direction"]).reshape(3, 3)
                np.testing.assert_allclose(direction @ np.diag(info["spacing"]), want[:3, :3],
                                           atol=1e-5)

    def test_warning_exactly_when_the_transforms_disagree(self):
        for name in self.files:
            with self.subTest(name):
                info, stderr = self.info(name)
                warnings = warning_lines(stderr)
                self.assertEqual(len(warnings), 1 if name == "disagree" else 0, stderr)
                self.assertEqual(len(info["warnings"]), len(warnings))
        stderr = self.info("disagree")[1]
        for text in ("qform (code 1", "sform (code 2", "12 -30 45", "-60 25 -10", "using the sform"):
            self.assertIn(text, stderr)

    def test_a_tenth_of_a_voxel_is_the_threshold(self):
        for shift_voxels, warned in ((0.05, False), (0.2, True)):
            with self.subTest(shift_voxels=shift_voxels):
                moved = SFORM.copy()
                moved[:3, 3] += moved[:3, 0] * shift_voxels  # along i, in voxels of 0.9 mm
                path = write_nifti(self.path(f"shift{shift_voxels}.nii.gz"), moved, 1, SFORM, 2)
                self.assertEqual(len(warning_lines(self.info(path)[1])), int(warned))

    def test_a_sheared_sform_is_used_as_its_nearest_rotation_and_said_so(self):
        sheared = SFORM.copy()
        sheared[0, 1] += 0.3  # x moves with j: no rotation and scaling does that
        path = write_nifti(self.path("sheared.nii.gz"), QFORM, 1, sheared, 2)
        info, stderr = self.info(path)
        warnings = warning_lines(stderr)
        self.assertEqual(len(warnings), 2, stderr)  # the disagreement, and the shear
        self.assertIn("sform is sheared", warnings[1])
        self.assertEqual(info["nifti"]["frame"], "sform")
        np.testing.assert_allclose(info["origin"], (LPS_FROM_RAS @ sheared)[:3, 3], atol=1e-4)
        direction = np.array(info["direction"]).reshape(3, 3)
        np.testing.assert_allclose(direction.T @ direction, np.eye(3), atol=1e-5)

    def test_mesh_overlays_the_image_in_the_default_frame(self):
        for name in self.files:
            with self.subTest(name):
                out, report, stderr = self.mesh(name)
                frame = self.default_frame[name]
                self.assert_overlays(out, name, frame)
                self.assertEqual(report["image"]["nifti"]["frame"], frame)
                self.assertEqual(report["parameters"]["nifti_frame"], "sform")
                self.assertEqual(len(warning_lines(stderr)), 1 if name == "disagree" else 0,
                                 stderr)

    def test_mesh_in_the_qform_by_option_and_by_preset(self):
        out, report, stderr = self.mesh("disagree", "--nifti-frame", "qform")
        self.assert_overlays(out, "disagree", "qform")
        self.assertEqual(report["image"]["nifti"]["frame"], "qform")
        self.assertEqual(report["parameters"]["nifti_frame"], "qform")
        self.assertIn("using the qform", stderr)
        # Not where the sform puts it: the two are far apart.
        self.assertGreater(np.abs(surface_deviation_voxels(out, self.expected_lps("disagree", "sform"))).max(),
                           5)
        preset = self.path("qform.json")
        with open(preset, "w") as f:
            json.dump({"nifti_frame": "qform"}, f)
        out, report, _ = self.mesh("disagree", "--preset", preset)
        self.assert_overlays(out, "disagree", "qform")
        self.assertEqual(report["image"]["nifti"]["frame"], "qform")

    def test_saved_preset_names_the_frame(self):
        preset = self.path("saved.json")
        r = run("mesh", self.files["equal"], "-o", self.path("saved.mesh"), "-q",
                "--nifti-frame", "qform", "--save-preset", preset)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(preset) as f:
            self.assertEqual(json.load(f)["nifti_frame"], "qform")

    def test_a_bad_frame_is_one_clear_line(self):
        bad_preset = self.path("bad.json")
        with open(bad_preset, "w") as f:
            json.dump({"nifti_frame": "scanner"}, f)
        runs = {
            "mesh option": run("mesh", self.files["equal"], "-o", self.path("bad.mesh"),
                               "--nifti-frame", "scanner"),
            "info option": run("info", self.files["equal"], "--nifti-frame", "scanner"),
            "preset": run("mesh", self.files["equal"], "-o", self.path("bad.mesh"),
                          "--preset", bad_preset),
        }
        for what, r in runs.items():
            with self.subTest(what):
                self.assertNotEqual(r.returncode, 0)
                lines = r.stderr.strip().splitlines()
                self.assertEqual(len(lines), 1, r.stderr)
                self.assertIn("nifti", lines[0])
                self.assertIn("scanner" if what != "preset" else "qform", lines[0])
        self.assertFalse(os.path.exists(self.path("bad.mesh")))


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
