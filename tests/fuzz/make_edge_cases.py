#!/usr/bin/python3
"""Writes the hand-made part of the fuzz seed corpus: small files, each exercising one branch of
a reader (a pixel type, an encoding, a byte order, a refusal). The valid files written by
cvtmesh itself come from scripts/make-fuzz-corpus, which calls this.

  make_edge_cases.py CORPUS_DIR     writes CORPUS_DIR/<target>/<name> for every target
"""
import gzip
import json
import os
import struct
import sys
import zlib
import base64

OUT = sys.argv[1]


def put(target, name, data):
    os.makedirs(os.path.join(OUT, target), exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(OUT, target, name), "wb") as f:
        f.write(data)


def voxels(count, fmt, endian="<", start=0):
    """`count` values 0, 1, 2, 0, ... packed as struct format `fmt`."""
    return struct.pack(endian + fmt * count, *[(start + i) % 3 for i in range(count)])


# --- NIfTI-1 / NIfTI-2 -------------------------------------------------------------------------
NIFTI_TYPES = {"uint8": (2, "B"), "int16": (4, "h"), "int32": (8, "i"), "float32": (16, "f"),
               "float64": (64, "d"), "int8": (256, "b"), "uint16": (512, "H"),
               "uint32": (768, "I"), "int64": (1024, "q"), "uint64": (1280, "Q")}


def nifti1(dims, dtype="uint8", endian="<", pixdim=(1, 1, 1), qform=0, sform=0, data=None,
           vox_offset=352, magic=b"n+1\0", intent=0):
    code, fmt = NIFTI_TYPES[dtype]
    h = bytearray(348)
    struct.pack_into(endian + "i", h, 0, 348)
    dim = [len(dims)] + list(dims) + [1] * (7 - len(dims))
    struct.pack_into(endian + "8h", h, 40, *dim)
    struct.pack_into(endian + "h", h, 68, intent)
    struct.pack_into(endian + "hh", h, 70, code, struct.calcsize(fmt) * 8)
    struct.pack_into(endian + "8f", h, 76, 1.0, *pixdim, 1, 1, 1, 1)
    struct.pack_into(endian + "f", h, 108, float(vox_offset))
    struct.pack_into(endian + "hh", h, 252, qform, sform)
    # qform: a rotation about z by 30 degrees; sform: a shear-free affine with an offset.
    struct.pack_into(endian + "6f", h, 256, 0.0, 0.0, 0.258819, 5.0, -3.0, 2.0)
    struct.pack_into(endian + "12f", h, 280, 1.5, 0, 0, 4, 0, 1.5, 0, -2, 0, 0, 2, 7)
    h[344:348] = magic
    count = 1
    for d in dims:
        count *= d
    if data is None:
        data = voxels(count, fmt, endian)
    return bytes(h) + b"\0" * (vox_offset - 348) + data


def nifti2(dims, dtype="uint8"):
    code, fmt = NIFTI_TYPES[dtype]
    h = bytearray(540)
    struct.pack_into("<i", h, 0, 540)
    h[4:12] = b"n+2\0\r\n\x1a\n"
    struct.pack_into("<hh", h, 12, code, struct.calcsize(fmt) * 8)
    struct.pack_into("<8q", h, 16, len(dims), *dims, *([1] * (7 - len(dims))))
    struct.pack_into("<8d", h, 104, 1.0, 0.5, 0.5, 2.0, 1, 1, 1, 1)
    struct.pack_into("<q", h, 168, 544)
    count = 1
    for d in dims:
        count *= d
    return bytes(h) + b"\0" * 4 + voxels(count, fmt)


def nifti_cases():
    t = "fuzz_nifti"
    for dtype in ("int16", "int32", "float32", "float64", "int8", "uint16", "uint32", "int64"):
        put(t, f"type_{dtype}.nii", nifti1((3, 2, 2), dtype))
    put(t, "big_endian_int16.nii", nifti1((2, 3, 2), "int16", endian=">"))
    put(t, "qform_rotated.nii", nifti1((3, 3, 2), qform=1, pixdim=(0.5, 0.7, 1.2)))
    put(t, "sform.nii", nifti1((2, 2, 3), sform=2))
    put(t, "label_beyond_2_24.nii",
        nifti1((2, 1, 1), "int32", data=struct.pack("<2i", 1, 16777217)))
    put(t, "is_2d.nii", nifti1((4, 4)))
    put(t, "is_4d.nii", nifti1((2, 2, 2, 2)))
    put(t, "vector.nii", nifti1((2, 2, 2, 1, 3), intent=1007))
    put(t, "truncated_data.nii", nifti1((4, 4, 4))[:352 + 20])
    put(t, "header_only.nii", nifti1((2, 2, 2))[:348])
    put(t, "nifti2.nii", nifti2((3, 2, 2), "int16"))
    put(t, "gzip_int16.nii.gz", gzip.compress(nifti1((3, 3, 3), "int16"), mtime=0))
    put(t, "gzip_truncated.nii.gz", gzip.compress(nifti1((5, 5, 5)), mtime=0)[:60])


# --- NRRD ----------------------------------------------------------------------------------------
def nrrd(sizes, type_="uchar", encoding="raw", endian="little", data=None, extra=""):
    fmt = {"uchar": "B", "short": "h", "int": "i", "float": "f", "double": "d",
           "ushort": "H", "int8": "b", "uint": "I", "longlong": "q"}[type_]
    count = 1
    for s in sizes:
        count *= s
    raw = voxels(count, fmt, "<" if endian == "little" else ">")
    if data is None:
        data = {"raw": raw, "gzip": gzip.compress(raw, mtime=0),
                "ascii": " ".join(str(i % 3) for i in range(count)).encode() + b"\n",
                "hex": raw.hex().encode() + b"\n"}[encoding]
    header = (f"NRRD0004\ntype: {type_}\ndimension: {len(sizes)}\n"
              f"sizes: {' '.join(map(str, sizes))}\nendian: {endian}\nencoding: {encoding}\n"
              f"{extra}\n")
    return header.encode() + data


def nrrd_cases():
    t = "fuzz_nrrd"
    put(t, "raw_short_big_endian.nrrd", nrrd((3, 2, 2), "short", endian="big"))
    put(t, "raw_float.nrrd", nrrd((2, 2, 3), "float"))
    put(t, "raw_double.nrrd", nrrd((2, 2, 2), "double"))
    put(t, "raw_int.nrrd", nrrd((2, 3, 2), "int"))
    put(t, "ascii_ushort.nrrd", nrrd((3, 3, 2), "ushort", encoding="ascii"))
    put(t, "hex_uchar.nrrd", nrrd((2, 2, 2), encoding="hex"))
    put(t, "gzip_uchar.nrrd", nrrd((4, 4, 4), encoding="gzip"))
    put(t, "space_directions.nrrd", nrrd(
        (3, 2, 2), extra="space: left-posterior-superior\n"
        "space directions: (0.5,0.1,0) (0,0.7,0) (0,0,1.5)\nspace origin: (10,-5,3)\n"))
    put(t, "spacings.nrrd", nrrd((2, 2, 2), extra="spacings: 0.25 0.5 2\n"))
    put(t, "label_beyond_2_24.nrrd", nrrd((2, 1, 1), "int", data=struct.pack("<2i", 1, 1 << 25)))
    put(t, "is_2d.nrrd", nrrd((4, 4)))
    put(t, "is_4d.nrrd", nrrd((2, 2, 2, 2)))
    put(t, "vector.nrrd", nrrd((3, 2, 2, 2), extra="kinds: vector domain domain domain\n"))
    put(t, "truncated_raw.nrrd", nrrd((6, 6, 6))[:-100])
    put(t, "truncated_gzip.nrrd", nrrd((6, 6, 6), encoding="gzip")[:-20])
    put(t, "bad_type.nrrd", nrrd((2, 2, 2), data=b"\0" * 8).replace(b"uchar", b"block"))


# --- MetaImage -----------------------------------------------------------------------------------
def mha(dims, element="MET_UCHAR", compressed=False, msb=False, data=None, extra=""):
    fmt = {"MET_UCHAR": "B", "MET_SHORT": "h", "MET_USHORT": "H", "MET_INT": "i",
           "MET_FLOAT": "f", "MET_DOUBLE": "d", "MET_CHAR": "b", "MET_UINT": "I",
           "MET_LONG_LONG": "q"}[element]
    count = 1
    for d in dims:
        count *= d
    raw = voxels(count, fmt, ">" if msb else "<") if data is None else data
    payload = zlib.compress(raw) if compressed else raw
    header = (f"ObjectType = Image\nNDims = {len(dims)}\nBinaryData = True\n"
              f"BinaryDataByteOrderMSB = {msb}\nCompressedData = {compressed}\n"
              + (f"CompressedDataSize = {len(payload)}\n" if compressed else "")
              + extra + f"DimSize = {' '.join(map(str, dims))}\nElementType = {element}\n"
              "ElementDataFile = LOCAL\n")
    return header.encode() + payload


def metaimage_cases():
    t = "fuzz_metaimage"
    for element in ("MET_SHORT", "MET_USHORT", "MET_INT", "MET_FLOAT", "MET_DOUBLE", "MET_CHAR"):
        put(t, f"type_{element.lower()}.mha", mha((3, 2, 2), element))
    put(t, "msb_short.mha", mha((2, 2, 3), "MET_SHORT", msb=True))
    put(t, "compressed.mha", mha((4, 4, 4), compressed=True))
    put(t, "transform.mha", mha((3, 3, 2), extra="TransformMatrix = 0 1 0 -1 0 0 0 0 1\n"
                                                   "Offset = 1 2 3\nElementSpacing = 0.5 1 2\n"))
    put(t, "label_beyond_2_24.mha",
        mha((2, 1, 1), "MET_INT", data=struct.pack("<2i", -1, -(1 << 25))))
    put(t, "is_2d.mha", mha((4, 4)))
    put(t, "is_4d.mha", mha((2, 2, 2, 2)))
    put(t, "channels.mha", mha((2, 2, 2), extra="ElementNumberOfChannels = 3\n",
                               data=voxels(24, "B")))
    put(t, "truncated.mha", mha((5, 5, 5))[:-30])
    put(t, "truncated_compressed.mha", mha((5, 5, 5), compressed=True)[:-5])
    put(t, "bad_spacing.mha", mha((2, 2, 2), extra="ElementSpacing = nan 1 -2\n"))


# --- INRIMAGE-4 ----------------------------------------------------------------------------------
def inr(dims, type_="unsigned fixed", bits=8, cpu="decm", vdim=1, extra="", data=None):
    fmt = {("unsigned fixed", 8): "B", ("unsigned fixed", 16): "H", ("signed fixed", 16): "h",
           ("signed fixed", 32): "i", ("float", 32): "f", ("float", 64): "d",
           ("signed fixed", 8): "b", ("unsigned fixed", 32): "I"}[(type_, bits)]
    text = (f"#INRIMAGE-4#{{\nXDIM={dims[0]}\nYDIM={dims[1]}\nZDIM={dims[2]}\nVDIM={vdim}\n"
            f"TYPE={type_}\nPIXSIZE={bits} bits\nSCALE=2**0\nCPU={cpu}\nVX=1\nVY=0.5\nVZ=2\n"
            f"{extra}")
    text += "\n" * (256 - (len(text) + 4) % 256 if (len(text) + 4) % 256 else 0) + "##}\n"
    endian = ">" if cpu in ("sun", "sgi") else "<"
    if data is None:
        data = voxels(dims[0] * dims[1] * dims[2] * vdim, fmt, endian)
    return text.encode() + data


def inr_cases():
    t = "fuzz_inr"
    put(t, "int16.inr", inr((3, 2, 2), "signed fixed", 16))
    put(t, "int32.inr", inr((2, 2, 2), "signed fixed", 32))
    put(t, "uint16_sun.inr", inr((2, 3, 2), "unsigned fixed", 16, cpu="sun"))
    put(t, "float32.inr", inr((2, 2, 3), "float", 32))
    put(t, "float64_sgi.inr", inr((2, 2, 2), "float", 64, cpu="sgi"))
    put(t, "origin.inr", inr((2, 2, 2), extra="TX=1.5\nTY=-2\nTZ=3\n"))
    put(t, "vdim3.inr", inr((2, 2, 2), vdim=3))
    put(t, "no_cpu.inr", inr((2, 2, 2), cpu="vax"))
    put(t, "negative_vx.inr", inr((2, 2, 2)).replace(b"VX=1\n", b"VX=-1\n"))
    put(t, "label_beyond_2_24.inr",
        inr((2, 1, 1), "signed fixed", 32, data=struct.pack("<2i", 0, 1 << 24 | 3)))
    put(t, "truncated.inr", inr((6, 6, 6))[:-50])
    put(t, "no_end_marker.inr", inr((2, 2, 2))[:200])
    put(t, "gzip_int16.inr.gz", gzip.compress(inr((3, 3, 3), "signed fixed", 16), mtime=0))


# --- Medit .mesh ---------------------------------------------------------------------------------
CUBE = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)]
TETS = [(1, 2, 3, 4), (2, 3, 4, 5)]


def medit(vertices=CUBE, tets=TETS, refs=(1, 2), extra=""):
    lines = ["MeshVersionFormatted 2", "Dimension 3", "", "Vertices", str(len(vertices))]
    lines += [f"{x} {y} {z} 0" for x, y, z in vertices]
    lines += ["", "Tetrahedra", str(len(tets))]
    lines += [" ".join(map(str, t)) + f" {r}" for t, r in zip(tets, refs)]
    return "\n".join(lines) + "\n" + extra + "End\n"


def medit_cases():
    t = "fuzz_mesh_medit"
    put(t, "two_tets.mesh", medit())
    put(t, "comments_triangles.mesh",
        "# written by hand\nMeshVersionFormatted 1\nDimension\n3\nVertices\n4\n0 0 0 1\n"
        "1 0 0 1\n0 1 0 1 # a comment\n0 0 1 1\nTriangles\n1\n1 2 3 7\nEdges\n1\n1 2 0\n"
        "Tetrahedra\n1\n1 3 2 4 5\nCorners\n1\n1\nEnd\n")
    put(t, "negative_orientation.mesh", medit(tets=[(1, 3, 2, 4)], refs=(3,)))
    put(t, "bad_index.mesh", medit(tets=[(1, 2, 3, 9)], refs=(1,)))
    put(t, "dimension_2.mesh", "MeshVersionFormatted 2\nDimension 2\nVertices\n1\n0 0 0\nEnd\n")
    put(t, "huge_count.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n99999999999\n")
    put(t, "non_finite.mesh", medit(vertices=[(0, 0, 0), (1, 0, 0), (0, 1, 0), ("nan", 0, 1)],
                                    tets=[(1, 2, 3, 4)], refs=(1,)))
    put(t, "no_end.mesh", medit().replace("End\n", "")[:-3])


# --- VTK XML .vtu --------------------------------------------------------------------------------
POINTS = [c for p in CUBE for c in p]
CONNECTIVITY = [v - 1 for t in TETS for v in t] + [0, 1, 2]
OFFSETS = [4, 8, 11]
TYPES = [10, 10, 5]  # two tets and a triangle (ignored)
LABELS = [3, 4, 7]


def pack(values, vtk_type, endian="<"):
    fmt = {"Float64": "d", "Float32": "f", "Int64": "q", "Int32": "i", "UInt8": "B",
           "UInt32": "I", "Int16": "h"}[vtk_type]
    return struct.pack(endian + fmt * len(values), *values)


def vtu(mode="ascii", header="UInt64", endian="<", zlib_=False, pieces=1, label_type="Int32"):
    """mode: ascii | binary (inline base64) | raw (appended raw) | appended (appended base64)."""
    code = "Q" if header == "UInt64" else "I"
    arrays = [("Points", "Float64", 3, POINTS, "Points"), ("connectivity", "Int64", 1,
              CONNECTIVITY, "Cells"), ("offsets", "Int64", 1, OFFSETS, "Cells"),
              ("types", "UInt8", 1, TYPES, "Cells"), ("label", label_type, 1, LABELS, "CellData")]
    appended = b""

    def block(values, vtk_type):
        data = pack(values, vtk_type, endian)
        if zlib_:
            comp = zlib.compress(data)
            return struct.pack(endian + code * 4, 1, len(data), len(data), len(comp)), comp
        return struct.pack(endian + code, len(data)), data

    xml = {}
    for name, vtk_type, comps, values, parent in arrays:
        attrs = f'type="{vtk_type}" Name="{name}" NumberOfComponents="{comps}"'
        if mode == "ascii":
            body = " ".join(map(str, values))
            xml[name] = f'<DataArray {attrs} format="ascii">{body}</DataArray>'
        elif mode == "binary":
            head, data = block(values, vtk_type)
            body = base64.b64encode(head).decode() + base64.b64encode(data).decode()
            xml[name] = f'<DataArray {attrs} format="binary">\n{body}\n</DataArray>'
        else:
            head, data = block(values, vtk_type)
            chunk = head + data if mode == "raw" else base64.b64encode(head + data)
            xml[name] = f'<DataArray {attrs} format="appended" offset="{len(appended)}"/>'
            appended += chunk
    order = "BigEndian" if endian == ">" else "LittleEndian"
    compressor = ' compressor="vtkZLibDataCompressor"' if zlib_ else ""
    piece = (f'<Piece NumberOfPoints="5" NumberOfCells="3">\n<Points>{xml["Points"]}</Points>\n'
             f'<Cells>{xml["connectivity"]}{xml["offsets"]}{xml["types"]}</Cells>\n'
             f'<CellData>{xml["label"]}</CellData>\n</Piece>\n')
    text = (f'<?xml version="1.0"?>\n<!-- a comment -->\n<VTKFile type="UnstructuredGrid" '
            f'version="1.0" byte_order="{order}" header_type="{header}"{compressor}>\n'
            f"<UnstructuredGrid>\n{piece * pieces}</UnstructuredGrid>\n").encode()
    if mode in ("raw", "appended"):
        encoding = "raw" if mode == "raw" else "base64"
        text += f'<AppendedData encoding="{encoding}">\n_'.encode() + appended
        text += b"\n</AppendedData>\n"
    return text + b"</VTKFile>\n"


def vtu_cases():
    t = "fuzz_mesh_vtu"
    put(t, "ascii.vtu", vtu("ascii"))
    put(t, "binary_uint32_header.vtu", vtu("binary", header="UInt32"))
    put(t, "binary_zlib.vtu", vtu("binary", zlib_=True))
    put(t, "appended_raw.vtu", vtu("raw"))
    put(t, "appended_base64_zlib.vtu", vtu("appended", zlib_=True, header="UInt32"))
    put(t, "big_endian.vtu", vtu("binary", endian=">"))
    put(t, "two_pieces.vtu", vtu("ascii", pieces=2))
    put(t, "float_labels.vtu", vtu("binary", label_type="Float64"))
    put(t, "truncated.vtu", vtu("raw")[:-60])
    put(t, "polydata.vtu", '<?xml version="1.0"?>\n<VTKFile type="PolyData"><PolyData>'
        '<Piece NumberOfPoints="0"/></PolyData></VTKFile>\n')


# --- presets -------------------------------------------------------------------------------------
def preset_cases():
    t = "fuzz_preset"
    put(t, "labels_list.json", json.dumps({"labels": [1, 2, 7], "r": 0.3, "seed": 42,
                                           "optimize": "default"}))
    put(t, "iso.json", json.dumps({"iso": 120.5, "inside_above": False, "labels": "all"}))
    put(t, "iso_null.json", '{"iso": null, "threads": 2, "max_memory_mb": 512.0}')
    put(t, "empty_object.json", "{}")
    put(t, "unknown_key.json", '{"sigma": 1}')
    put(t, "wrong_type.json", '{"margin_voxels": "4"}')
    put(t, "out_of_range.json", '{"r": 1.5, "max_iterations": -1}')
    put(t, "not_object.json", "[1, 2, 3]")
    put(t, "big_numbers.json", '{"seed": 18446744073709551615, "threads": 4294967297, '
        '"interior_points": -9223372036854775808, "epsilon_mm": 1e308}')
    put(t, "escapes.json", '{"optimize": "n\\u006fne", "labels": [1e2]}')
    put(t, "truncated.json", '{"labels": [1, 2')
    put(t, "optimization.json", json.dumps({"optimize": "default", "optimization": {
        "target_dihedral_deg": 18, "max_passes": 3, "flips": False, "odt_passes": 1,
        "global_flip_below": 2.5}}))


nifti_cases()
nrrd_cases()
metaimage_cases()
inr_cases()
medit_cases()
vtu_cases()
preset_cases()
