#!/usr/bin/python3
"""Runs examples/mesh_image on an image of a torus and checks the file it writes: readable by
meshio, valid with a closed genus-1 boundary by `cvtmesh quality --json`, and the very file
`cvtmesh mesh` writes for the same image.

Usage: check_mesh_image.py MESH_IMAGE CVTMESH IMAGE OUT.vtu   (ctest, Debian's /usr/bin/python3)
"""
import json
import os
import subprocess
import sys
import unittest

import meshio

MESH_IMAGE, CVTMESH, IMAGE, OUT = sys.argv[1:5]


class MeshImage(unittest.TestCase):
    def test_writes_a_valid_mesh(self):
        if os.path.exists(OUT):
            os.remove(OUT)
        r = subprocess.run([MESH_IMAGE, IMAGE, OUT], capture_output=True, text=True, timeout=300)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn(" tets -> ", r.stdout)
        tets = meshio.read(OUT).get_cells_type("tetra")
        self.assertGreater(len(tets), 1000)
        q = subprocess.run([CVTMESH, "quality", OUT, "--json"], capture_output=True, text=True,
                           timeout=300)
        self.assertEqual(q.returncode, 0, q.stderr)
        report = json.loads(q.stdout)
        self.assertEqual(report["tets"], len(tets))
        validity = report["validity"]
        self.assertTrue(validity["valid"], validity)
        self.assertTrue(validity["boundary_closed_manifold"])
        self.assertEqual(validity["euler_characteristic"], 0)  # a torus
        self.assertEqual(validity["boundary_components"], 1)
        # Stage 6 ran: no sliver is left.
        self.assertGreater(report["dihedral_deg"]["min"], 5.0)
        # The example says it does what `cvtmesh mesh` does with the default parameters.
        cli_out = OUT + ".cli.vtu"
        c = subprocess.run([CVTMESH, "mesh", IMAGE, "-o", cli_out, "-q"], capture_output=True,
                           text=True, timeout=300)
        self.assertEqual(c.returncode, 0, c.stderr)
        with open(OUT, "rb") as a, open(cli_out, "rb") as b:
            self.assertTrue(a.read() == b.read(),
                            f"{OUT} differs from {cli_out}: the example no longer follows the "
                            "pipeline's stages or defaults")


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]], verbosity=2)
