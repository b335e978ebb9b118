#!/usr/bin/env python3
"""The mesh does not depend on the CPU: GCC picks each kernel's AVX2 or baseline (SSE2) version
at load time, and both must round alike. Runs cvtmesh natively and under qemu-user emulating a
CPU without AVX (so every dispatcher picks the baseline), and compares the files byte for byte.
Usage: test_isa_independence.py CVTMESH QEMU SOURCE_DIR"""
import hashlib
import os
import subprocess
import sys
import tempfile
import unittest

CVTMESH, QEMU, SOURCE = sys.argv[1:4]
TORUS = os.path.join(SOURCE, "assets", "phantom_torus.nii.gz")


def digest(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


class IsaIndependence(unittest.TestCase):
    def test_baseline_and_avx2_give_the_same_mesh(self):
        with tempfile.TemporaryDirectory() as out:
            native, emulated = os.path.join(out, "native.vtu"), os.path.join(out, "baseline.vtu")
            subprocess.run([CVTMESH, "mesh", TORUS, "-o", native, "-q"], check=True)
            # Nehalem: SSE4.2, no AVX; qemu's CPUID says so and GCC's dispatchers follow it.
            subprocess.run([QEMU, "-cpu", "Nehalem", CVTMESH, "mesh", TORUS, "-o", emulated, "-q"],
                           check=True, timeout=600)
            self.assertGreater(os.path.getsize(native), 10000)
            self.assertEqual(digest(native), digest(emulated))


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]], verbosity=2)
