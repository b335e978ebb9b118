#!/usr/bin/python3
"""A solver's view of a tet mesh, independent of cvtmesh: the iterations Jacobi-preconditioned
conjugate gradients needs on the P1 Laplacian assembled from it (−Δu = 1 inside, u = 0 on the
boundary), with numpy and scipy. Badly shaped elements make the matrix ill-conditioned and the
count grow.

Usage: laplacian_cg.py MESH [--rtol 1e-8]   (any format meshio reads; prints JSON)
"""
import argparse
import json
import sys

import meshio
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def stiffness(points, tets):
    """The P1 stiffness matrix: per tet, vol · ∇λa · ∇λb of its barycentric coordinates."""
    x0 = points[tets[:, 0]]
    jac = np.stack([points[tets[:, k]] - x0 for k in (1, 2, 3)], axis=2)  # columns x_k − x0
    vol = np.abs(np.linalg.det(jac)) / 6.0
    inv = np.linalg.inv(jac)  # rows: ∇λ1, ∇λ2, ∇λ3
    grads = np.concatenate([-inv.sum(axis=1, keepdims=True), inv], axis=1)  # (m, 4, 3)
    local = vol[:, None, None] * np.einsum("mai,mbi->mab", grads, grads)
    rows = np.repeat(tets, 4, axis=1).ravel()
    cols = np.tile(tets, (1, 4)).ravel()
    n = len(points)
    return sp.csr_matrix((local.ravel(), (rows, cols)), shape=(n, n)), vol


def boundary_vertices(tets):
    faces = np.sort(np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]],
                                    tets[:, [0, 1, 2]]]), axis=1)
    unique, counts = np.unique(faces, axis=0, return_counts=True)
    return np.unique(unique[counts == 1].ravel())


def cg_iterations(path, rtol=1e-8):
    mesh = meshio.read(path)
    tets = np.concatenate([c.data for c in mesh.cells if c.type == "tetra"]).astype(np.int64)
    used = np.unique(tets.ravel())
    points = np.asarray(mesh.points, dtype=np.float64)
    k, vol = stiffness(points, tets)
    load = np.zeros(len(points))
    np.add.at(load, tets.ravel(), np.repeat(vol / 4.0, 4))  # ∫ φ_i, lumped
    free = np.setdiff1d(used, boundary_vertices(tets))
    a = k[free][:, free].tocsr()
    b = load[free]
    diag = a.diagonal()
    jacobi = spla.LinearOperator(a.shape, matvec=lambda r: r / diag)
    count = [0]

    def step(_):
        count[0] += 1

    try:
        u, info = spla.cg(a, b, M=jacobi, rtol=rtol, atol=0.0, maxiter=100000, callback=step)
    except TypeError:  # scipy < 1.12 calls it tol
        u, info = spla.cg(a, b, M=jacobi, tol=rtol, atol=0.0, maxiter=100000, callback=step)
    return {"iterations": count[0], "converged": info == 0, "unknowns": int(len(free)),
            "rtol": rtol, "max_u": float(u.max()) if len(u) else 0.0}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mesh")
    ap.add_argument("--rtol", type=float, default=1e-8)
    a = ap.parse_args()
    json.dump(cg_iterations(a.mesh, a.rtol), sys.stdout)
    print()


if __name__ == "__main__":
    main()
