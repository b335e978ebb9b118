#!/usr/bin/python3
"""bench/laplacian_cg.py, the solver's view bench/compare reports: its P1 stiffness matrix on a
structured tet mesh of a cube, and its CG count (which must grow when elements get worse).

Usage: test_laplacian_cg.py SOURCE_DIR   (run by ctest with Debian's /usr/bin/python3)
"""
import os
import sys
import tempfile
import unittest

import meshio
import numpy as np

SOURCE = sys.argv[1] if len(sys.argv) > 1 else "."
sys.dont_write_bytecode = True  # no bench/__pycache__
sys.path.insert(0, os.path.join(SOURCE, "bench"))
import laplacian_cg  # noqa: E402


def cube_mesh(n, nz=None):
    """The unit cube, n × n × nz cells of six tets each (Kuhn)."""
    nz = nz or n
    pts = np.array([[i / n, j / n, k / nz] for k in range(nz + 1) for j in range(n + 1)
                    for i in range(n + 1)])
    idx = lambda i, j, k: i + (n + 1) * (j + (n + 1) * k)  # noqa: E731
    tets = []
    for k in range(nz):
        for j in range(n):
            for i in range(n):
                c = [idx(i + a, j + b, k + d) for d in (0, 1) for b in (0, 1) for a in (0, 1)]
                for p in ([0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7],
                          [0, 4, 6, 7]):
                    t = [c[q] for q in p]
                    a, b, e, f = pts[t]
                    if np.linalg.det(np.array([b - a, e - a, f - a])) < 0:
                        t[2], t[3] = t[3], t[2]
                    tets.append(t)
    return pts, np.array(tets)


class Stiffness(unittest.TestCase):
    def test_constants_and_linear_functions_are_harmonic(self):
        pts, tets = cube_mesh(4)
        k, vol = laplacian_cg.stiffness(pts, tets)
        self.assertAlmostEqual(vol.sum(), 1.0, places=12)
        self.assertLess(np.abs(k @ np.ones(len(pts))).max(), 1e-12)
        inner = np.setdiff1d(np.arange(len(pts)), laplacian_cg.boundary_vertices(tets))
        self.assertEqual(len(inner), 27)
        lin = pts @ np.array([0.3, -1.2, 2.0])
        self.assertLess(np.abs((k @ lin)[inner]).max(), 1e-12)


class Iterations(unittest.TestCase):
    def count(self, pts, tets):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "cube.mesh")
            meshio.write(path, meshio.Mesh(pts, [("tetra", tets)]))
            return laplacian_cg.cg_iterations(path)

    def test_solves_poisson_and_worse_elements_need_more_iterations(self):
        good = self.count(*cube_mesh(16))
        self.assertTrue(good["converged"])
        self.assertEqual(good["unknowns"], 15 ** 3)
        # −Δu = 1 on the unit cube, u = 0 on its boundary: u(centre) = 0.05622 (series).
        self.assertAlmostEqual(good["max_u"], 0.05622, delta=0.003)
        # The same vertices, the inner ones shaken by up to a fifth of a cell (seeded; no tet
        # inverts): worse elements, more iterations for the same unknowns.
        pts, tets = cube_mesh(16)
        inner = np.setdiff1d(np.arange(len(pts)), laplacian_cg.boundary_vertices(tets))
        pts[inner] += np.random.default_rng(1).uniform(-0.2, 0.2, (len(inner), 3)) / 16
        _, vol = laplacian_cg.stiffness(pts, tets)
        x0 = pts[tets[:, 0]]
        jac = np.stack([pts[tets[:, k]] - x0 for k in (1, 2, 3)], axis=2)
        self.assertGreater(np.linalg.det(jac).min(), 0)
        shaken = self.count(pts, tets)
        self.assertTrue(shaken["converged"])
        self.assertEqual(shaken["unknowns"], good["unknowns"])
        self.assertGreater(shaken["iterations"], 1.4 * good["iterations"])


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1])
