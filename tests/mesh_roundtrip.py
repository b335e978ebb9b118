#!/usr/bin/python3
"""Independent check of the files cvtmesh writes, read with meshio (FEBio with ElementTree,
as meshio has no FEBio reader). Run with the Debian python that has meshio and numpy.

  mesh_roundtrip.py FILE VERTICES CELLS VOLUME [--bounds X0 Y0 Z0 X1 Y1 Z1] [--triangles N]
      Tet formats (.mesh .vtu .msh .inp .feb .node .ele): exactly VERTICES points and CELLS
      tetrahedra, all positively oriented, of total volume VOLUME; with --triangles, also N
      boundary triangles. Surfaces (.stl .ply .obj): VERTICES distinct points and CELLS
      triangles forming a closed, consistently oriented surface that encloses VOLUME
      (outward normals). --bounds checks the bounding box of the points.
  mesh_roundtrip.py --convert IN OUT [ascii|binary|zlib]
      Rewrites IN with meshio (fixtures for the C++ readers); the mode applies to .vtu.
Exit status 0 when every check passes; otherwise one line on stderr says what failed.
"""
import sys
import xml.etree.ElementTree as ET

import meshio
import numpy as np

TET_FORMATS = {".mesh", ".vtu", ".msh", ".inp", ".feb", ".node", ".ele"}
SURFACE_FORMATS = {".stl", ".ply", ".obj"}


def fail(message):
    print(f"mesh_roundtrip: {message}", file=sys.stderr)
    sys.exit(1)


def suffix(path):
    dot = path.rfind(".")
    return path[dot:].lower() if dot >= 0 else ""


def read_febio(path):
    mesh = ET.parse(path).getroot().find("Mesh")
    if mesh is None:
        fail(f"{path}: no <Mesh>")
    ids, points = {}, []
    for node in mesh.iter("node"):
        ids[int(node.get("id"))] = len(points)
        points.append([float(x) for x in node.text.split(",")])
    tets, triangles = [], []
    for elements in mesh.iter("Elements"):
        if elements.get("type") != "tet4":
            fail(f"{path}: unexpected element type {elements.get('type')}")
        for elem in elements.iter("elem"):
            tets.append([ids[int(i)] for i in elem.text.split(",")])
    for tri in mesh.iter("tri3"):
        triangles.append([ids[int(i)] for i in tri.text.split(",")])
    return np.array(points, dtype=float), np.array(tets, dtype=int), len(triangles)


def read_cells(path):
    """Points, tetrahedra and the number of triangles of a file."""
    if suffix(path) == ".feb":
        return read_febio(path)
    mesh = meshio.read(path)
    tets = [block.data for block in mesh.cells if block.type == "tetra"]
    triangles = sum(len(block.data) for block in mesh.cells if block.type == "triangle")
    tets = np.concatenate(tets) if tets else np.zeros((0, 4), dtype=int)
    return np.asarray(mesh.points, dtype=float), tets, triangles


def check_bounds(points, bounds):
    lo, hi = points.min(axis=0), points.max(axis=0)
    want = np.array(bounds, dtype=float)
    if not (np.allclose(lo, want[:3], rtol=1e-6, atol=1e-6) and np.allclose(hi, want[3:], rtol=1e-6, atol=1e-6)):
        fail(f"bounds {lo.tolist()} {hi.tolist()}, expected {want.tolist()}")


def check_volume(volume, expected, tolerance):
    if abs(volume - expected) > tolerance * max(1.0, abs(expected)):
        fail(f"volume {volume!r}, expected {expected!r}")


def check_tets(path, vertices, cells, volume, triangles):
    points, tets, num_triangles = read_cells(path)
    if len(points) != vertices:
        fail(f"{path}: {len(points)} points, expected {vertices}")
    if len(tets) != cells:
        fail(f"{path}: {len(tets)} tetrahedra, expected {cells}")
    a, b, c, d = (points[tets[:, i]] for i in range(4))
    volumes = np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6.0
    if np.any(volumes <= 0):
        fail(f"{path}: {int(np.sum(volumes <= 0))} tetrahedra are not positively oriented")
    check_volume(float(volumes.sum()), volume, 1e-9)
    if triangles is not None and num_triangles != triangles:
        fail(f"{path}: {num_triangles} triangles, expected {triangles}")
    return points


def check_surface(path, vertices, cells, volume):
    mesh = meshio.read(path)
    tris = np.concatenate([b.data for b in mesh.cells if b.type == "triangle"])
    # STL repeats each corner; merge equal positions so the topology can be checked.
    points, inverse = np.unique(np.asarray(mesh.points, dtype=float), axis=0, return_inverse=True)
    tris = inverse.reshape(-1)[tris]
    if len(points) != vertices:
        fail(f"{path}: {len(points)} distinct points, expected {vertices}")
    if len(tris) != cells:
        fail(f"{path}: {len(tris)} triangles, expected {cells}")
    # Closed and consistently oriented: every directed edge is matched by its reverse once.
    directed = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    forward = {tuple(e) for e in directed.tolist()}
    if len(forward) != len(directed) or any((b, a) not in forward for a, b in forward):
        fail(f"{path}: the surface is not closed and consistently oriented")
    a, b, c = (points[tris[:, i]] for i in range(3))
    enclosed = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)
    check_volume(enclosed, volume, 1e-5 if suffix(path) == ".stl" else 1e-9)
    return points


def convert(source, target, mode):
    mesh = meshio.read(source)
    if suffix(target) == ".vtu":
        meshio.vtu.write(target, mesh, binary=mode != "ascii", compression="zlib" if mode == "zlib" else None)
    else:
        meshio.write(target, mesh)


def main(argv):
    if len(argv) >= 3 and argv[0] == "--convert":
        convert(argv[1], argv[2], argv[3] if len(argv) > 3 else "binary")
        return
    if len(argv) < 4:
        fail(__doc__)
    path, vertices, cells, volume = argv[0], int(argv[1]), int(argv[2]), float(argv[3])
    options = argv[4:]
    bounds = triangles = None
    while options:
        if options[0] == "--bounds" and len(options) >= 7:
            bounds, options = options[1:7], options[7:]
        elif options[0] == "--triangles" and len(options) >= 2:
            triangles, options = int(options[1]), options[2:]
        else:
            fail(f"unknown option {options[0]}")
    kind = suffix(path)
    if kind in TET_FORMATS:
        points = check_tets(path, vertices, cells, volume, triangles)
    elif kind in SURFACE_FORMATS:
        points = check_surface(path, vertices, cells, volume)
    else:
        fail(f"{path}: unknown format {kind}")
    if bounds is not None:
        check_bounds(points, bounds)
    print(f"OK {path}: {len(points)} points")


if __name__ == "__main__":
    main(sys.argv[1:])
