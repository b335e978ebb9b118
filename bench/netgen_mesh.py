#!/usr/bin/python3
"""One NETGEN volume mesh of a closed surface (the marching-cubes STL), for bench/compare.

Usage: netgen_mesh.py SURFACE.stl OUT.mesh --maxh H [--optsteps3d N] [--stl NAME=VALUE ...]

Runs Debian's NETGEN 6.2 (python3-netgen) headless with its STL pipeline and default parameters
except maxh (largest element size, mm), optsteps3d (volume optimisation steps: 0 = none, NETGEN's
default 3) and the STL parameters given with --stl, writes the tets as Medit .mesh and prints
JSON: {"read_s", "mesh_s", "vertices", "tets", "stl_parameters"}. read_s is the STL reading
(ASCII: this NETGEN reads no binary STL through Python), mesh_s the rest: STL analysis (edges,
charts), surface meshing and surface optimisation, volume meshing and, with optsteps3d > 0,
volume optimisation — one call, NETGEN gives no split.

NETGEN 6.2.1905's Python API does not expose the STL parameters (edge detection and chart
angles, the local-h restrictions); they live in the global netgen::stlparam of libstl, which
--stl sets through ctypes after checking that the library's defaults sit where expected.
"""
import ctypes
import argparse
import json
import os
import sys
import time

import numpy as np
from netgen.stl import LoadSTLGeometry
import netgen.meshing as ngm


class StlParameters(ctypes.Structure):
    """The leading fields of netgen::STLParameters (stlgeom/stltool.hpp, NETGEN 6.2.1905)."""
    _fields_ = [("yangle", ctypes.c_double), ("contyangle", ctypes.c_double),
                ("edgecornerangle", ctypes.c_double), ("chartangle", ctypes.c_double),
                ("outerchartangle", ctypes.c_double), ("usesearchtree", ctypes.c_int),
                ("resthatlasfac", ctypes.c_double), ("resthatlasenable", ctypes.c_int),
                ("atlasminh", ctypes.c_double), ("resthsurfcurvfac", ctypes.c_double),
                ("resthsurfcurvenable", ctypes.c_int), ("resthchartdistfac", ctypes.c_double),
                ("resthchartdistenable", ctypes.c_int)]


STL_DEFAULTS = {"yangle": 30, "contyangle": 20, "edgecornerangle": 60, "chartangle": 15,
                "outerchartangle": 70, "resthatlasfac": 2, "resthchartdistfac": 1.2,
                "resthchartdistenable": 1}


def set_stl_parameters(settings):
    """Sets netgen::stlparam fields (NAME=VALUE strings); returns all the fields' values."""
    lib = ctypes.CDLL("libstl.so.6.2", mode=ctypes.RTLD_GLOBAL)  # the copy netgen.stl loaded
    p = StlParameters.in_dll(lib, "_ZN6netgen8stlparamE")
    found = {k: getattr(p, k) for k in STL_DEFAULTS}
    if found != STL_DEFAULTS:
        sys.exit(f"netgen::stlparam is not laid out as expected (found {found}): "
                 "another NETGEN version? Run without --stl")
    for kv in settings:
        name, _, value = kv.partition("=")
        if name not in dict(StlParameters._fields_):
            sys.exit(f"--stl {kv}: unknown STL parameter '{name}'")
        setattr(p, name, type(getattr(p, name))(float(value)))
    return {name: getattr(p, name) for name, _ in StlParameters._fields_}


def write_medit(path, points, tets):
    """Vertices and tets (1-based) as Medit .mesh, through a temp file so no half file is left."""
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(f"MeshVersionFormatted 2\nDimension 3\nVertices\n{len(points)}\n")
        np.savetxt(f, np.hstack([points, np.zeros((len(points), 1))]), fmt="%.17g %.17g %.17g %d")
        f.write(f"Tetrahedra\n{len(tets)}\n")
        np.savetxt(f, np.hstack([tets, np.ones((len(tets), 1), dtype=np.int64)]), fmt="%d")
        f.write("End\n")
    os.replace(tmp, path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("surface")
    ap.add_argument("out")
    ap.add_argument("--maxh", type=float, required=True)
    ap.add_argument("--optsteps3d", type=int, default=3)
    ap.add_argument("--stl", action="append", default=[], metavar="NAME=VALUE",
                    help="an STL parameter of netgen::stlparam, e.g. yangle=180")
    a = ap.parse_args()
    if not os.path.exists(a.surface):
        sys.exit(f"{a.surface}: no such file")
    stl_parameters = set_stl_parameters(a.stl) if a.stl else "defaults"
    ngm.SetMessageImportance(0)
    t0 = time.perf_counter()
    geometry = LoadSTLGeometry(a.surface)
    t1 = time.perf_counter()
    mesh = geometry.GenerateMesh(maxh=a.maxh, optsteps3d=a.optsteps3d)
    t2 = time.perf_counter()
    points = np.array([p.p for p in mesh.Points()], dtype=float)
    tets = np.array([[v.nr for v in e.vertices] for e in mesh.Elements3D()], dtype=np.int64)
    if len(tets) == 0:
        sys.exit(f"{a.surface}: NETGEN made no tetrahedra (maxh {a.maxh})")
    # NETGEN orders a tet's vertices the other way round from the usual positive orientation:
    # one swap for all tets (per-tet inversions, if any, stay visible to the quality check).
    p = points[tets - 1]
    signed = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    if np.sum(signed < 0) > len(signed) / 2:
        tets[:, [1, 2]] = tets[:, [2, 1]]
    write_medit(a.out, points, tets)
    print(json.dumps({"read_s": t1 - t0, "mesh_s": t2 - t1, "vertices": len(points),
                      "tets": len(tets), "stl_parameters": stl_parameters}))


if __name__ == "__main__":
    main()
