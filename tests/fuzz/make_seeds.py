#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Writes the small seed corpora of the mesh fuzz targets
(tests/fuzz/seeds_mesh_<ext>/): valid files of a few hundred bytes covering
each reader's variants. The OM seeds are written by OpenMesh itself
(tests/fuzz/make_om_seeds.cpp). Usage: python3 tests/fuzz/make_seeds.py"""
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
CUBE_V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
CUBE_Q = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
CUBE_T = [t for q in CUBE_Q for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
TET_V = [(0, 0, 0), (2, 0, 0), (0, 3, 0), (0, 0, 4)]
TET_T = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]


def put(ext, name, data):
    d = os.path.join(HERE, "seeds_mesh_" + ext)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name + "." + ext), "wb") as f:
        f.write(data)


def fmt(x):
    return "%g" % x


# OBJ
put("obj", "cube_quads", "# unit cube\no cube\n" + "".join("v %s\n" % " ".join(map(fmt, v)) for v in CUBE_V)
    + "".join("f %s\n" % " ".join(str(i + 1) for i in q) for q in CUBE_Q))
put("obj", "tetra_forms", "mtllib t.mtl\ng t\ns 1\nusemtl m\nvt 0 0\nvt 1 0\nvn 0 0 1\n"
    "v 0 0 0 1\nv 2 0 0 0.5 0.5 0.5\nv 0 3 0\nv 0 0 4 # last\n"
    "f 1/1 3/2 2/1\nf 1//1 2//1 4//1\nf 2/1/1 3/2/1 4/-1/-1\nf -4/-2/-1 -1/-1/-1 -2/1/1\nl 1 2\n")
put("obj", "tetra_relative_crlf", "v 0 0 0\r\nv 2e0 0 0\r\nv 0 3.0 -0\r\nv .0 +0 4\r\nf -4 -2 -3\r\nf 1 2 4\r\n"
    "f 2 3 4\r\nf 1 4 3 2\r\nf 1 2")
put("obj", "forward_refs", "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\nv 0 0 0\nv 2 0 0\nv 0 3 0\nv 0 0 4\n")

# OFF
put("off", "cube", "OFF\n8 12 18\n" + "".join("%s\n" % " ".join(map(fmt, v)) for v in CUBE_V)
    + "".join("3 %d %d %d\n" % t for t in CUBE_T))
put("off", "tetra_comments", "# a tetrahedron\nOFF # header\n# counts next\n4 4 6\n\n0 0 0 # origin\n2 0 0\n#\n"
    "0 3 0\n0 0 4\n3 0 2 1\n3 0 1 3\n# last two\n3 1 2 3\n3 0 3 2\n")
put("off", "coff_counts_on_header", "COFF 4 4 6\n0 0 0 255 0 0 255\n2 0 0 0 255 0 255\n0 3 0 0 0 255 255\n"
    "0 0 4 9 9 9 255\n3 0 2 1 1 2 3\n3 0 1 3\n3 1 2 3 0.5 0.5 0.5\n4 0 3 2 1\n")
put("off", "noff", "NOFF\n4 4 6\n0 0 0 0 0 1\n2 0 0 0 0 1\n0 3 0 0 0 1\n0 0 4 0 0 1\n3 0 2 1\n3 0 1 3\n"
    "3 1 2 3\n3 0 3 2\n")
put("off", "cube_binary", b"OFF BINARY\n" + struct.pack("<3I", 8, 12, 0)
    + b"".join(struct.pack("<3f", *v) for v in CUBE_V) + b"".join(struct.pack("<4I", 3, *t) for t in CUBE_T))

# PLY
def ply_ascii(comment=""):
    s = ("ply\nformat ascii 1.0\n%selement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
         "property uchar red\nelement face 6\nproperty list uchar int vertex_indices\nend_header\n" % comment)
    s += "".join("%s 255\n" % " ".join(map(fmt, v)) for v in CUBE_V)
    s += "".join("4 %d %d %d %d\n" % q for q in CUBE_Q)
    return s


def ply_binary(endian, word):
    e = "<" if endian == "little" else ">"
    s = ("ply\nformat binary_%s_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
         "property float z\nelement face 4\nproperty list uchar %s vertex_indices\nend_header\n" % (endian, word)).encode()
    code = {"int": "i", "uint": "I", "short": "h", "ushort": "H"}[word]
    s += b"".join(struct.pack(e + "3f", *v) for v in TET_V)
    s += b"".join(struct.pack(e + "B3" + code, 3, *t) for t in TET_T)
    return s


put("ply", "cube_ascii_quads", ply_ascii("comment unit cube\n"))
put("ply", "tetra_binary_le", ply_binary("little", "int"))
put("ply", "tetra_binary_be", ply_binary("big", "uint"))
put("ply", "tetra_binary_le_short", ply_binary("little", "short"))
put("ply", "tetra_ascii_double_normals",
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\n"
    "property float nx\nproperty float ny\nproperty float nz\nelement face 4\n"
    "property list uchar uint vertex_index\nelement edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n"
    + "".join("%s 0 0 1\n" % " ".join(map(fmt, v)) for v in TET_V) + "".join("3 %d %d %d\n" % t for t in TET_T)
    + "0 1\n")

# STL
def stl_ascii(tris, verts):
    s = "solid t\n"
    for t in tris:
        s += "  facet normal 0 0 0\n    outer loop\n"
        s += "".join("      vertex %s\n" % " ".join(map(fmt, verts[i])) for i in t)
        s += "    endloop\n  endfacet\n"
    return s + "endsolid t\n"


def stl_binary(header, tris, verts):
    h = header.encode().ljust(80, b" ")
    return h + struct.pack("<I", len(tris)) + b"".join(
        struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *verts[i]) for i in t) + b"\0\0" for t in tris)


put("stl", "tetra_ascii", stl_ascii(TET_T, TET_V))
put("stl", "tetra_binary", stl_binary("binary tetra", TET_T, TET_V))
put("stl", "tetra_binary_solid_header", stl_binary("solid but binary", TET_T, TET_V))
put("stl", "cube_binary", stl_binary("cube", CUBE_T, CUBE_V))
