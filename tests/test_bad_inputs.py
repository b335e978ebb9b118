#!/usr/bin/python3
"""A corpus of bad inputs through every entry point: `cvtmesh info`, `cvtmesh mesh`,
`cvtmesh quality` and the viewer's scripted mode (`cvtmesh-gui IMAGE --run-all --screenshot
X.png --exit` on a private Xvfb display).

Each bad input must give a non-zero exit (not a signal), exactly one line on stderr that
names the file and says what is wrong, and leave its output folder empty (no temp files).
The corpus is made here at test time: small files written with struct/gzip/numpy, and real
files from cvtmesh-phantom and cvtmesh cut short or garbled.

Root ignores file permissions, and CI runs as root, so the "unreadable file" and "read-only
folder" cases run as the unprivileged user nobody (setpriv) when the test runs as root.

Usage: test_bad_inputs.py CVTMESH PHANTOM SOURCE_DIR [GUI]   (ctest, Debian's /usr/bin/python3)
"""
import concurrent.futures
import gzip
import os
import random
import re
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import unittest

import numpy as np

CVTMESH = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build/app/cvtmesh")
PHANTOM = os.path.abspath(sys.argv[2] if len(sys.argv) > 2 else "build/tests/phantoms/cvtmesh-phantom")
SOURCE = os.path.abspath(sys.argv[3] if len(sys.argv) > 3 else ".")
GUI = os.path.abspath(sys.argv[4]) if len(sys.argv) > 4 and sys.argv[4] else None
TORUS = os.path.join(SOURCE, "assets", "phantom_torus.nii.gz")
NOBODY = 65534
AS_NOBODY = (["setpriv", f"--reuid={NOBODY}", f"--regid={NOBODY}", "--clear-groups"]
             if os.geteuid() == 0 else [])
# Words that mean a library's raw exception or a crash reached the user.
NOT_CLEAR = ["terminate called", "what():", "std::", "itk::", "ExceptionObject", "Assertion",
             "Segmentation", "AddressSanitizer", "runtime error:", "Aborted"]


def run(cmd, timeout=300, as_nobody=False, env=None):
    prefix = AS_NOBODY if as_nobody else []
    return subprocess.run(prefix + cmd, capture_output=True, text=True, timeout=timeout,
                          env=env, errors="replace")


def run_all(cmds, **kwargs):
    """run() over many commands at once (they are small; most of their time is start-up)."""
    with concurrent.futures.ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        return list(pool.map(lambda c: run(c[0], as_nobody=c[1], **kwargs), cmds))


# ---- writers for the corpus ---------------------------------------------------------------


def write(path, data):
    with open(path, "wb") as f:
        f.write(data)
    return path


def nrrd(path, array, type_name, extra=""):
    a = np.asarray(array)
    header = (f"NRRD0004\ntype: {type_name}\ndimension: {a.ndim}\n"
              f"sizes: {' '.join(str(s) for s in reversed(a.shape))}\n"
              f"encoding: raw\nendian: little\n{extra}\n")
    return write(path, header.encode() + a.astype(a.dtype.newbyteorder("<")).tobytes())


def nifti(path, dims, datatype=2, bitpix=8, data=None, compress=None):
    """A NIfTI-1 single file (.nii or .nii.gz). dims: the sizes, their count is dim[0]."""
    h = bytearray(348)
    struct.pack_into("<i", h, 0, 348)
    dim = [len(dims)] + list(dims) + [1] * (7 - len(dims))
    struct.pack_into("<8h", h, 40, *dim)
    struct.pack_into("<hh", h, 70, datatype, bitpix)
    struct.pack_into("<8f", h, 76, 1, 1, 1, 1, 1, 1, 1, 1)
    struct.pack_into("<f", h, 108, 352.0)  # vox_offset
    struct.pack_into("<f", h, 112, 1.0)  # scl_slope
    struct.pack_into("<hh", h, 252, 0, 0)  # qform_code, sform_code
    h[344:348] = b"n+1\0"
    if data is None:
        count = 1
        for d in dims:
            count *= d
        data = bytes(count * bitpix // 8)
    blob = bytes(h) + bytes(4) + data
    gz = path.endswith(".gz") if compress is None else compress
    return write(path, gzip.compress(blob, mtime=0) if gz else blob)


def read(path):
    with open(path, "rb") as f:
        return f.read()


def cut(src, dst, fraction):
    data = read(src)
    return write(dst, data[: int(len(data) * fraction)])


def garbage(n, seed):
    rng = random.Random(seed)
    return bytes(rng.randrange(256) for _ in range(n))


# ---- checks ---------------------------------------------------------------------------------


class Corpus(unittest.TestCase):
    """Builds the corpus once; each test method runs it through one entry point."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        os.chmod(cls.tmp.name, 0o755)  # nobody must reach the files it is meant to read
        cls.root = cls.tmp.name
        cls.images = cls.make_images()
        cls.meshes = cls.make_meshes()

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    @classmethod
    def path(cls, name):
        return os.path.join(cls.root, name)

    @classmethod
    def make_images(cls):
        """(name, path, what the message must say besides the path, as_nobody)."""
        p = cls.path
        subprocess.run([PHANTOM, "torus", "--size", "6", "-o", p("torus.inr")], check=True)
        subprocess.run([PHANTOM, "torus", "--size", "6", "-o", p("torus.nrrd")], check=True)
        subprocess.run([PHANTOM, "torus", "--size", "6", "-o", p("torus.mha")], check=True)
        subprocess.run([PHANTOM, "torus", "--size", "6", "-o", p("torus.nii")], check=True)
        zeros = np.zeros((6, 7, 8), np.uint8)
        grey = np.linspace(0, 1, 6 * 7 * 8, dtype=np.float32).reshape(6, 7, 8)
        with_nan, with_inf = grey.copy(), grey.copy()
        with_nan[3, 3, 3] = np.nan
        with_inf[2, 2, 2] = np.inf
        unreadable = write(p("unreadable.nii.gz"), read(TORUS))
        os.chmod(unreadable, 0o600)  # root's; nobody may not read it
        os.mkdir(p("folder.nii.gz"))
        cases = [
            ("missing", p("missing.nii.gz"), "no such file", False),
            ("empty nii.gz", write(p("empty.nii.gz"), b""), "", False),
            ("empty nrrd", write(p("empty.nrrd"), b""), "", False),
            ("empty inr", write(p("empty.inr"), b""), "", False),
            ("garbage nii", write(p("garbage.nii"), garbage(3000, 1)), "", False),
            ("garbage nii.gz", write(p("garbage.nii.gz"), garbage(3000, 2)), "", False),
            ("gzipped garbage nii.gz",
             write(p("gzgarbage.nii.gz"), gzip.compress(garbage(3000, 3), mtime=0)), "", False),
            ("garbage inr.gz", write(p("garbage.inr.gz"), gzip.compress(garbage(3000, 4))), "",
             False),
            ("garbage mha", write(p("garbage.mha"), garbage(3000, 5)), "", False),
            ("nrrd header then garbage",
             write(p("badhead.nrrd"), b"NRRD0004\n" + garbage(500, 6)), "", False),
            ("truncated inr", cut(p("torus.inr"), p("cut.inr"), 0.6), "", False),
            ("truncated nrrd", cut(p("torus.nrrd"), p("cut.nrrd"), 0.6), "", False),
            ("truncated mha", cut(p("torus.mha"), p("cut.mha"), 0.6), "", False),
            ("truncated nii", cut(p("torus.nii"), p("cut.nii"), 0.6), "", False),
            ("header only nii", cut(p("torus.nii"), p("head.nii"), 0.01), "", False),
            ("2D nifti", nifti(p("flat.nii.gz"), [5, 6]), "2D", False),
            ("2D nrrd", nrrd(p("flat.nrrd"), np.ones((5, 6), np.uint8), "uint8"), "2D", False),
            ("4D nifti", nifti(p("time.nii.gz"), [4, 4, 4, 3]), "4D", False),
            ("absurd nifti dims", nifti(p("huge.nii"), [30000, 30000, 30000], data=bytes(64)),
             "", False),
            ("absurd inr dims", write(p("huge.inr"), inr_header(200000, 200000, 200000)), "",
             False),
            ("negative nrrd size",
             write(p("negative.nrrd"), b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: -4 4 4\n"
                   b"encoding: raw\n\n" + bytes(64)), "", False),
            ("all-zero labels", nrrd(p("zeros.nrrd"), zeros, "uint8"), "no voxel", False),
            ("NaN in a grey image", nrrd(p("nan.nrrd"), with_nan, "float"), "NaN", False),
            ("Inf in a grey image", nrrd(p("inf.nrrd"), with_inf, "float"), "infinite", False),
            ("zero spacing",
             nrrd(p("flatvoxels.nrrd"), np.ones((6, 7, 8), np.uint8), "uint8",
                  "spacings: 1 0 1\n"), "spacing", False),
            # (NRRD reads a NaN spacing as "unknown", i.e. 1: not an error there.)
            ("NaN spacing", write(p("nanvoxels.mha"), mha_header("nan 1 1") + bytes(336)),
             "spacing nan (ElementSpacing) is not a positive finite number", False),
            ("Inf spacing", write(p("infvoxels.mha"), mha_header("1 inf 1") + bytes(336)),
             "spacing inf (ElementSpacing) is not a positive finite number", False),
            ("zero spacing mha", write(p("flatvoxels.mha"), mha_header("1 1 0") + bytes(336)),
             "spacing 0 (ElementSpacing) is not a positive finite number", False),
            ("negative spacing mha",
             write(p("flipvoxels.mha"), mha_header("1 -0.5 1") + bytes(336)),
             "spacing -0.5 (ElementSpacing) is not a positive finite number", False),
            ("two spacings mha", write(p("twovoxels.mha"), mha_header("1 1") + bytes(336)),
             "ElementSpacing gives 2 voxel spacings for NDims = 3", False),
            ("a folder", p("folder.nii.gz"), "", False),
            ("unreadable file", unreadable, "", True),
        ]
        return cases

    @classmethod
    def make_meshes(cls):
        p = cls.path
        good_mesh, good_vtu = p("good.mesh"), p("good.vtu")
        for out in (good_mesh, good_vtu):
            r = run([CVTMESH, "mesh", TORUS, "-q", "--max-iterations", "3", "-o", out])
            assert r.returncode == 0, r.stderr
        vtu = read(good_vtu)
        tet = ("MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 1\n1 0 0 1\n0 1 0 1\n"
               "{z} 1\nTetrahedra\n1\n1 2 3 {v} 1\nEnd\n")
        unreadable = write(p("unreadable.mesh"), read(good_mesh))
        os.chmod(unreadable, 0o600)
        os.mkdir(p("folder.mesh"))
        return [
            ("missing mesh", p("missing.mesh"), "no such file", False),
            ("empty mesh", write(p("empty.mesh"), b""), "", False),
            ("empty vtu", write(p("empty.vtu"), b""), "", False),
            ("garbage mesh", write(p("garbage.mesh"), garbage(2000, 7)), "", False),
            ("garbage vtu", write(p("garbage.vtu"), garbage(2000, 8)), "", False),
            ("truncated mesh", cut(good_mesh, p("cut.mesh"), 0.5), "", False),
            ("truncated vtu", cut(good_vtu, p("cut.vtu"), 0.5), "", False),
            ("vtu with broken base64", write(p("b64.vtu"), vtu_points_line(vtu, lambda l: b"@" * len(l))),
             "", False),
            ("vtu with short base64", write(p("short.vtu"), vtu_points_line(vtu, lambda l: l[: len(l) // 2])),
             "", False),
            ("NaN coordinate", write(p("nan.mesh"), tet.format(z="0 0 nan", v=4).encode()),
             "non-finite", False),
            ("index out of range", write(p("range.mesh"), tet.format(z="0 0 1", v=9).encode()),
             "vertex 9", False),
            ("index zero", write(p("zero.mesh"), tet.format(z="0 0 1", v=0).encode()),
             "vertex index 0", False),
            ("absurd count",
             write(p("count.mesh"), b"MeshVersionFormatted 2\nDimension 3\nVertices\n"
                   b"999999999999\n0 0 0 1\nEnd\n"), "count", False),
            ("no tetrahedra",
             write(p("notets.mesh"), b"MeshVersionFormatted 2\nDimension 3\nVertices\n1\n"
                   b"0 0 0 1\nEnd\n"), "no tetrahedra", False),
            ("2D mesh", write(p("flat.mesh"), b"MeshVersionFormatted 2\nDimension 2\nEnd\n"),
             "Dimension 2", False),
            ("vtu out of range", write(p("range.vtu"), vtu_ascii([0, 1, 2, 7])), "index 7", False),
            ("vtu NaN", write(p("nan.vtu"), vtu_ascii([0, 1, 2, 3], z="nan")), "", False),
            ("a folder", p("folder.mesh"), "", False),
            ("unreadable mesh", unreadable, "", True),
        ]

    # -- the assertion every case shares --

    def assert_refused(self, result, names, must_say="", quiet_lines=None):
        """Non-zero exit, no signal, one clear stderr line naming `names`."""
        stderr = result.stderr
        self.assertNotEqual(result.returncode, 0, "accepted: " + stderr)
        self.assertGreater(result.returncode, 0, "killed by a signal: " + stderr)
        self.assertLess(result.returncode, 128, "crashed: " + stderr)
        lines = [l for l in stderr.splitlines() if l.strip()] if quiet_lines is None else quiet_lines
        self.assertEqual(len(lines), 1, "expected one line:\n" + stderr)
        line = lines[0]
        self.assertIn(names, line)
        if must_say:
            self.assertIn(must_say, line)
        for word in NOT_CLEAR:
            self.assertNotIn(word, line)
        self.assertLess(len(line), 400, line)
        return line

    def assert_empty(self, folder):
        self.assertEqual(os.listdir(folder), [], "output left behind")

    def fresh_folder(self, writable_by_nobody=False):
        d = tempfile.mkdtemp(dir=self.root)
        if writable_by_nobody:
            os.chmod(d, 0o777)
        return d

    # -- the entry points --

    def test_info(self):
        cases = [c for c in self.images
                 if c[0] not in ("all-zero labels", "NaN in a grey image", "Inf in a grey image")]
        # (those are readable: info describes them, test_info_describes_odd_but_readable_images)
        results = run_all([([CVTMESH, "info", path], nobody) for _, path, _, nobody in cases])
        for (name, path, say, _), r in zip(cases, results):
            with self.subTest(name):
                self.assert_refused(r, path, say)

    def test_info_describes_odd_but_readable_images(self):
        r = run([CVTMESH, "info", self.path("zeros.nrrd")])
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("0 .. 0", r.stdout)
        for name in ("nan.nrrd", "inf.nrrd"):
            r = run([CVTMESH, "info", self.path(name)])
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("non-finite: 1 voxel", r.stdout)
            self.assertIn("range:      0 .. 1", r.stdout)  # of the finite values

    def test_mesh(self):
        outs = [self.fresh_folder(writable_by_nobody=c[3]) for c in self.images]
        cmds = []
        for (_, path, _, nobody), out in zip(self.images, outs):
            mesh = [CVTMESH, "mesh", path, "--iso", "0.5", "-o", os.path.join(out, "out.vtu")]
            cmds += [(mesh + ["-q"], nobody), (mesh, nobody)]
        results = run_all(cmds)
        for i, ((name, path, say, _), out) in enumerate(zip(self.images, outs)):
            quiet, loud = results[2 * i], results[2 * i + 1]
            with self.subTest(name):
                line = self.assert_refused(quiet, path, say)
                self.assert_empty(out)
                # With progress lines, the error is the same single line, last (figures such as
                # the available memory may differ between the two runs).
                digits = lambda text: re.sub(r"[0-9]+", "N", text)
                self.assertEqual([digits(l) for l in loud.stderr.splitlines()[-1:]], [digits(line)],
                                 loud.stderr)
                self.assertEqual(sum(digits(line) == digits(l) for l in loud.stderr.splitlines()), 1)
                self.assertEqual(loud.returncode, quiet.returncode)

    def test_quality_with_bad_image(self):
        good = self.path("good.mesh")
        results = run_all([([CVTMESH, "quality", good, "--image", path, "--iso", "0.5"], nobody)
                           for _, path, _, nobody in self.images])
        for (name, path, say, _), r in zip(self.images, results):
            with self.subTest(name):
                self.assert_refused(r, path, say)

    def test_quality_with_bad_mesh(self):
        results = run_all([([CVTMESH, "quality", path], nobody) for _, path, _, nobody in self.meshes])
        for (name, path, say, _), r in zip(self.meshes, results):
            with self.subTest(name):
                self.assert_refused(r, path, say)

    def test_quality_judges_inverted_and_degenerate_tets(self):
        # Not refused: judging such meshes is what `quality` is for.
        tet = ("MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 1\n1 0 0 1\n0 1 0 1\n"
               "0 0 {z} 1\nTetrahedra\n1\n1 2 3 4 1\nEnd\n")
        inverted = write(self.path("inverted.mesh"), tet.format(z=-1).encode())
        r = run([CVTMESH, "quality", inverted, "--json"])
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn('"inverted": 0', r.stdout)  # reoriented on reading
        flat = write(self.path("flat_tet.mesh"), tet.format(z=0).encode())
        r = run([CVTMESH, "quality", flat])
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("NOT VALID", r.stdout)
        self.assertIn("zero volume 1", r.stdout)

    def test_mesh_files_are_not_images(self):
        for cmd in (["info"], ["mesh", "-q", "-o", self.path("x.vtu")]):
            with self.subTest(cmd[0]):
                p = self.path("good.mesh")
                self.assert_refused(run([CVTMESH, cmd[0], p] + cmd[1:]), p, "unsupported")

    def test_viewer(self):
        if not GUI:
            self.skipTest("cvtmesh-gui not built")
        outs = [self.fresh_folder(writable_by_nobody=c[3]) for c in self.images]
        with XvfbDisplay() as display:
            env = dict(os.environ, DISPLAY=display, MESA_SHADER_CACHE_DISABLE="true",
                       HOME=self.root)
            results = run_all([([GUI, path, "--run-all", "--screenshot",
                                 os.path.join(out, "shot.png"), "--exit"], nobody)
                               for (_, path, _, nobody), out in zip(self.images, outs)],
                              env=env, timeout=120)
        for (name, path, say, _), out, r in zip(self.images, outs, results):
            with self.subTest(name):
                line = self.assert_refused(r, path, say)
                self.assertTrue(line.startswith("cvtmesh-gui: "), line)
                self.assert_empty(out)


class OutputPaths(unittest.TestCase):
    """Outputs that cannot be written: refused before the work, nothing left behind."""

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        os.chmod(self.tmp.name, 0o755)
        self.root = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def refused(self, args, names, must_say="", as_nobody=False):
        r = run([CVTMESH, "mesh", TORUS, "-q"] + args, as_nobody=as_nobody)
        Corpus.assert_refused(self, r, names, must_say)
        return r

    def test_missing_folder(self):
        out = os.path.join(self.root, "no", "such", "t.vtu")
        self.refused(["-o", out], out, "does not exist")
        self.assertEqual(os.listdir(self.root), [])

    def test_read_only_folder(self):
        ro = os.path.join(self.root, "ro")
        os.mkdir(ro, 0o555)
        os.chown(ro, NOBODY, NOBODY) if os.geteuid() == 0 else None
        out = os.path.join(ro, "t.vtu")
        self.refused(["-o", out], out, "", as_nobody=True)
        self.assertEqual(os.listdir(ro), [])

    def test_proc(self):
        self.refused(["-o", "/proc/cvtmesh-test.vtu"], "/proc/cvtmesh-test.vtu")

    def test_output_is_a_folder(self):
        out = os.path.join(self.root, "t.vtu")
        os.mkdir(out)
        self.refused(["-o", out], out, "folder")
        self.assertEqual(os.listdir(self.root), ["t.vtu"])
        self.assertEqual(os.listdir(out), [])

    def test_unknown_extension(self):
        out = os.path.join(self.root, "t.xyz")
        self.refused(["-o", out], out, "unsupported")
        self.assertEqual(os.listdir(self.root), [])

    def test_report_and_preset_that_cannot_be_written_leave_no_mesh(self):
        out = os.path.join(self.root, "t.vtu")
        for option in ("--report", "--save-preset"):
            with self.subTest(option):
                bad = os.path.join(self.root, "missing", "r.json")
                self.refused(["-o", out, option, bad], bad)
                self.assertEqual(os.listdir(self.root), [])
                self.refused(["-o", out, option, "/proc/r.json"], "/proc/r.json")
                self.assertEqual(os.listdir(self.root), [])


class Presets(unittest.TestCase):
    """Bad presets: one line naming the file and the key, before any work."""

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.root = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def test_bad_presets(self):
        cases = [
            ('{"r": 0.3, "radius": 2}', "unknown parameter 'radius'"),
            ('{"r": "big"}', "r: expected a number"),
            ('{"r": -0.4}', "r: must be in (0, 1)"),
            ('{"sigma_surface_mm": 0}', "sigma_surface_mm: must be > 0"),
            ('{"epsilon_mm": -1e-3}', "epsilon_mm: must be >= 0"),
            ('{"max_iterations": -1}', "max_iterations: must be in"),
            ('{"max_iterations": 2.5}', "max_iterations: expected an integer"),
            ('{"seed": -3}', "seed: must not be negative"),
            ('{"threads": 1e9}', "threads: expected an integer"),
            ('{"fill_cavities": 1}', "fill_cavities: expected true or false"),
            ('{"labels": [1, "x"]}', "labels"),
            ('{"optimize": "fast"}', "optimize"),
            ('{"iso": "mid"}', "iso: expected a number"),
            ('{"max_points": 0}', "max_points: must be > 0"),
            ('{"lfs_min_mm": 3, "lfs_max_mm": 2}', "lfs_max_mm"),
            ('[0.3]', "expected a JSON object"),
            ('{"r": 0.3,', "not valid JSON"),
            ("", "not valid JSON"),
        ]
        for i, (text, say) in enumerate(cases):
            with self.subTest(text):
                preset = os.path.join(self.root, f"p{i}.json")
                with open(preset, "w") as f:
                    f.write(text)
                out = tempfile.mkdtemp(dir=self.root)
                r = run([CVTMESH, "mesh", TORUS, "-o", os.path.join(out, "t.vtu"), "--preset", preset])
                Corpus.assert_refused(self, r, preset, say)
                self.assertEqual(os.listdir(out), [])

    def test_bad_preset_in_the_viewer(self):
        if not GUI:
            self.skipTest("cvtmesh-gui not built")
        preset = os.path.join(self.root, "p.json")
        with open(preset, "w") as f:
            f.write('{"sigma_surface_mm": 0}')
        out = tempfile.mkdtemp(dir=self.root)
        with XvfbDisplay() as display:
            env = dict(os.environ, DISPLAY=display, MESA_SHADER_CACHE_DISABLE="true")
            r = run([GUI, TORUS, "--preset", preset, "--run-all", "--screenshot",
                     os.path.join(out, "s.png"), "--exit"], env=env, timeout=120)
        Corpus.assert_refused(self, r, preset, "sigma_surface_mm")
        self.assertEqual(os.listdir(out), [])


class CommandLine(unittest.TestCase):
    """Bad options: one line naming the option or parameter, before any work."""

    def test_bad_options(self):
        with tempfile.TemporaryDirectory() as out:
            mesh = [CVTMESH, "mesh", TORUS, "-o", os.path.join(out, "t.vtu")]
            cases = [
                (mesh + ["--r", "abc"], "--r"),
                (mesh + ["--r", "-0.5"], "r: must be in (0, 1)"),
                (mesh + ["--sigma-surface", "0"], "sigma_surface_mm: must be > 0"),
                (mesh + ["--epsilon", "-1"], "epsilon_mm: must be >= 0"),
                (mesh + ["--max-iterations", "-1"], "max_iterations"),
                (mesh + ["--bogus", "1"], "--bogus"),
                (mesh + ["--optimize", "fast"], "--optimize"),
                ([CVTMESH, "mesh", TORUS], "--output"),
                ([CVTMESH, "info"], "IMAGE"),
                ([CVTMESH, "frobnicate"], "subcommand"),
            ]
            for cmd, say in cases:
                with self.subTest(" ".join(cmd[1:])):
                    r = run(cmd)
                    Corpus.assert_refused(self, r, say)
                    self.assertTrue(r.stderr.startswith("cvtmesh: "), r.stderr)
                    self.assertEqual(os.listdir(out), [])


# ---- helpers that need the module's names -----------------------------------------------------


def mha_header(spacing):
    return (f"ObjectType = Image\nNDims = 3\nDimSize = 8 7 6\nElementSpacing = {spacing}\n"
            "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n").encode()


def inr_header(x, y, z):
    h = (f"#INRIMAGE-4#{{\nXDIM={x}\nYDIM={y}\nZDIM={z}\nVDIM=1\nTYPE=unsigned fixed\n"
         "PIXSIZE=8 bits\nCPU=decm\nVX=1\nVY=1\nVZ=1\n")
    return (h + "\n" * (252 - len(h)) + "##}\n").encode() + bytes(64)


def vtu_points_line(vtu, change):
    """The .vtu with its (base64) points line changed."""
    lines = vtu.split(b"\n")
    i = next(i for i, l in enumerate(lines) if b'Name="Points"' in l) + 1
    lines[i] = change(lines[i])
    return b"\n".join(lines)


def vtu_ascii(tet, z="1"):
    return f"""<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
<UnstructuredGrid><Piece NumberOfPoints="4" NumberOfCells="1">
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">
0 0 0  1 0 0  0 1 0  0 0 {z}
</DataArray></Points>
<Cells>
<DataArray type="Int64" Name="connectivity" format="ascii">{' '.join(map(str, tet))}</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">4</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">10</DataArray>
</Cells></Piece></UnstructuredGrid></VTKFile>
""".encode()


class XvfbDisplay:
    """A private X server for the viewer runs (one for many runs: xvfb-run per run is slow)."""

    def __enter__(self):
        xvfb = shutil.which("Xvfb")
        if not xvfb:
            raise unittest.SkipTest("Xvfb not installed (scripts/install-deps installs xvfb)")
        read_fd, write_fd = os.pipe()
        # -noreset: without it the server resets whenever its last client leaves, and a viewer
        # run that connects during the reset fails ("Failed to open display"; seen in CI).
        self.proc = subprocess.Popen([xvfb, "-displayfd", str(write_fd), "-screen", "0",
                                      "1280x800x24", "-nolisten", "tcp", "-noreset"],
                                     pass_fds=[write_fd], stderr=subprocess.DEVNULL)
        os.close(write_fd)
        with os.fdopen(read_fd) as f:
            number = f.readline().strip()
        if not number:
            raise RuntimeError("Xvfb did not start")
        return ":" + number

    def __exit__(self, *exc):
        self.proc.send_signal(signal.SIGTERM)
        self.proc.wait(timeout=30)


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]], verbosity=2)
