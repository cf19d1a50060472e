# SPDX-License-Identifier: Apache-2.0
"""Writes one small scene in the formats clvox reads through Assimp, and the
same triangles flattened into an OBJ (tests/test_assimp.c):

    scene.glb, scene.gltf + scene.bin, scene.3mf, scene.dae, flat.obj,
    truncated.glb (scene.glb cut in half),
    many_placements.glb (one 20,000-triangle mesh placed by 2,000 nodes:
    a 270 KB file whose flattened scene, 724 MB, passes clvox's bound),
    buffer_dir.gltf, buffer_fifo.gltf, buffer_zero.gltf (scene.gltf with its
    buffer URI naming a directory, a FIFO, and a link to /dev/zero)

The scene: a unit cube placed by two nodes (as is, and scaled by 2 and moved
to (3, 0.5, 0)), and a tetrahedron under the second node (its own move of
(0, 0, 1), so at (3, 0.5, 2) scaled by 2): a mesh instanced twice and a
transform composed through two levels. The glTF files also hold one line
primitive, which clvox leaves out and counts. Every coordinate and matrix
entry is exact in float, so the flattened vertices are exact too.

FBX is not made here (no writer in Python's standard library):
tests/test_assimp.c exports scene.glb to FBX with Assimp's own exporter.

usage: make_scenes.py DIR
"""
import json
import os
import struct
import sys
import zipfile

CUBE_V = [(x, y, z) for z in (0, 1) for y in (0, 1) for x in (0, 1)]
# outward-facing triangles of the unit cube (vertex index = x + 2y + 4z)
CUBE_T = [(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4),
          (2, 6, 3), (3, 6, 7), (0, 4, 2), (2, 4, 6), (1, 3, 5), (3, 7, 5)]
TET_V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TET_T = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]

# world transforms as (scale, translation)
PLACEMENTS = [("cube", 1.0, (0.0, 0.0, 0.0)),
              ("cube", 2.0, (3.0, 0.5, 0.0)),
              ("tet", 2.0, (3.0, 0.5, 2.0))]
MESHES = {"cube": (CUBE_V, CUBE_T), "tet": (TET_V, TET_T)}


def flat_obj(path):
    lines, base = [], 1
    faces = []
    for name, s, t in PLACEMENTS:
        v, tr = MESHES[name]
        for p in v:
            lines.append("v %.17g %.17g %.17g" % tuple(s * p[a] + t[a] for a in range(3)))
        faces += ["f %d %d %d" % tuple(base + i for i in f) for f in tr]
        base += len(v)
    with open(path, "w") as f:
        f.write("\n".join(lines + faces) + "\n")


def gltf_parts():
    blob = b""
    views, accessors = [], []

    def add(data, target, count, ctype, atype, extra=None):
        nonlocal blob
        while len(blob) % 4:
            blob += b"\0"
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
        acc = {"bufferView": len(views) - 1, "componentType": ctype, "count": count, "type": atype}
        if extra:
            acc.update(extra)
        accessors.append(acc)
        blob += data
        return len(accessors) - 1

    def pos(vs):
        mn = [min(p[a] for p in vs) for a in range(3)]
        mx = [max(p[a] for p in vs) for a in range(3)]
        return add(struct.pack("<%df" % (3 * len(vs)), *[c for p in vs for c in p]), 34962, len(vs), 5126,
                   "VEC3", {"min": mn, "max": mx})

    def idx(ts):
        flat = [i for t in ts for i in t]
        return add(struct.pack("<%dH" % len(flat), *flat), 34963, len(flat), 5123, "SCALAR")

    meshes = []
    for name in ("cube", "tet"):
        v, t = MESHES[name]
        meshes.append({"name": name, "primitives": [{"attributes": {"POSITION": pos(v)}, "indices": idx(t),
                                                     "mode": 4}]})
    line = pos([(0, 0, 0), (1, 1, 1)])
    meshes.append({"name": "line", "primitives": [{"attributes": {"POSITION": line}, "mode": 1}]})
    # node 2: scale 2, move (3, 0.5, 0), as a column-major matrix
    m2 = [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 3, 0.5, 0, 1]
    nodes = [{"name": "root", "children": [1, 2, 4]},
             {"name": "a", "mesh": 0},
             {"name": "b", "mesh": 0, "matrix": m2, "children": [3]},
             {"name": "c", "mesh": 1, "translation": [0, 0, 1]},
             {"name": "l", "mesh": 2}]
    doc = {"asset": {"version": "2.0", "generator": "clvox tests/make_scenes.py"},
           "scene": 0, "scenes": [{"nodes": [0]}], "nodes": nodes, "meshes": meshes,
           "accessors": accessors, "bufferViews": views}
    while len(blob) % 4:
        blob += b"\0"
    return doc, blob


def write_gltf(d):
    doc, blob = gltf_parts()
    doc["buffers"] = [{"uri": "scene.bin", "byteLength": len(blob)}]
    with open(os.path.join(d, "scene.bin"), "wb") as f:
        f.write(blob)
    with open(os.path.join(d, "scene.gltf"), "w") as f:
        json.dump(doc, f, indent=1)


def write_glb(d):
    doc, blob = gltf_parts()
    doc["buffers"] = [{"byteLength": len(blob)}]
    js = json.dumps(doc).encode()
    while len(js) % 4:
        js += b" "
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(blob), 0x004E4942) + blob
    data = struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body
    with open(os.path.join(d, "scene.glb"), "wb") as f:
        f.write(data)
    with open(os.path.join(d, "truncated.glb"), "wb") as f:
        f.write(data[:len(data) // 2])


def write_3mf(d):
    def obj(oid, name):
        v, t = MESHES[name]
        vs = "".join('<vertex x="%g" y="%g" z="%g"/>' % p for p in v)
        ts = "".join('<triangle v1="%d" v2="%d" v3="%d"/>' % f for f in t)
        return ('<object id="%d" type="model"><mesh><vertices>%s</vertices><triangles>%s</triangles>'
                '</mesh></object>' % (oid, vs, ts))
    items = []
    for name, s, t in PLACEMENTS:
        oid = 1 if name == "cube" else 2
        m = "%g 0 0 0 %g 0 0 0 %g %g %g %g" % (s, s, s, t[0], t[1], t[2])
        items.append('<item objectid="%d" transform="%s"/>' % (oid, m))
    model = ('<?xml version="1.0" encoding="UTF-8"?>\n'
             '<model unit="millimeter" xml:lang="en-US" '
             'xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02">'
             '<resources>%s%s</resources><build>%s</build></model>' % (obj(1, "cube"), obj(2, "tet"), "".join(items)))
    types = ('<?xml version="1.0" encoding="UTF-8"?>\n'
             '<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">'
             '<Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>'
             '<Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>'
             '</Types>')
    rels = ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">'
            '<Relationship Target="/3D/3dmodel.model" Id="rel0" '
            'Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>')
    with zipfile.ZipFile(os.path.join(d, "scene.3mf"), "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("[Content_Types].xml", types)
        z.writestr("_rels/.rels", rels)
        z.writestr("3D/3dmodel.model", model)


def write_dae(d):
    def geom(name):
        v, t = MESHES[name]
        pos = " ".join("%g" % c for p in v for c in p)
        idx = " ".join("%d" % i for f in t for i in f)
        return ('<geometry id="%s"><mesh><source id="%s-p"><float_array id="%s-a" count="%d">%s</float_array>'
                '<technique_common><accessor source="#%s-a" count="%d" stride="3"><param name="X" type="float"/>'
                '<param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common>'
                '</source><vertices id="%s-v"><input semantic="POSITION" source="#%s-p"/></vertices>'
                '<triangles count="%d"><input semantic="VERTEX" source="#%s-v" offset="0"/><p>%s</p></triangles>'
                '</mesh></geometry>' % (name, name, name, 3 * len(v), pos, name, len(v), name, name, len(t), name, idx))
    # <matrix> is row-major
    scene = ('<node id="a"><instance_geometry url="#cube"/></node>'
             '<node id="b"><matrix>2 0 0 3 0 2 0 0.5 0 0 2 0 0 0 0 1</matrix><instance_geometry url="#cube"/>'
             '<node id="c"><translate>0 0 1</translate><instance_geometry url="#tet"/></node></node>')
    doc = ('<?xml version="1.0" encoding="utf-8"?>\n'
           '<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">'
           '<asset><unit name="meter" meter="1"/><up_axis>Y_UP</up_axis></asset>'
           '<library_geometries>%s%s</library_geometries>'
           '<library_visual_scenes><visual_scene id="s">%s</visual_scene></library_visual_scenes>'
           '<scene><instance_visual_scene url="#s"/></scene></COLLADA>\n' % (geom("cube"), geom("tet"), scene))
    with open(os.path.join(d, "scene.dae"), "w") as f:
        f.write(doc)


def write_many_placements(d, nodes=2000, n=100):
    """A GLB whose one mesh (an n x n grid of squares, 2 n^2 triangles) is
    placed by `nodes` nodes: valid glTF, small, and a flattened scene far
    larger than clvox allows for a file of its size."""
    vs = [(float(i), float(j), 0.0) for j in range(n + 1) for i in range(n + 1)]
    ts = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            ts += [(a, a + 1, a + n + 1), (a + 1, a + n + 2, a + n + 1)]
    pos = struct.pack("<%df" % (3 * len(vs)), *[c for p in vs for c in p])
    idx = struct.pack("<%dH" % (3 * len(ts)), *[i for t in ts for i in t])
    blob = pos + idx
    doc = {"asset": {"version": "2.0", "generator": "clvox tests/make_scenes.py"},
           "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": [{"children": list(range(1, nodes + 1))}] + [{"mesh": 0}] * nodes,
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(vs), "type": "VEC3",
                          "min": [0, 0, 0], "max": [n, n, 0]},
                         {"bufferView": 1, "componentType": 5123, "count": 3 * len(ts), "type": "SCALAR"}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos), "target": 34962},
                           {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx), "target": 34963}],
           "buffers": [{"byteLength": len(blob)}]}
    js = json.dumps(doc, separators=(",", ":")).encode()
    while len(js) % 4:
        js += b" "
    while len(blob) % 4:
        blob += b"\0"
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(blob), 0x004E4942) + blob
    with open(os.path.join(d, "many_placements.glb"), "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)


def write_bad_buffers(d):
    """scene.gltf with its buffer naming what is not a regular file."""
    doc, _ = gltf_parts()
    targets = {"dir": "buffer_dir.d", "fifo": "buffer_fifo.bin", "zero": "buffer_zero.bin"}
    for kind, name in targets.items():
        p = os.path.join(d, name)
        if os.path.lexists(p):
            if os.path.isdir(p) and not os.path.islink(p):
                os.rmdir(p)
            else:
                os.remove(p)
        if kind == "dir":
            os.mkdir(p)
        elif kind == "fifo":
            os.mkfifo(p)
        else:
            os.symlink("/dev/zero", p)
        doc["buffers"] = [{"uri": name, "byteLength": 264}]
        with open(os.path.join(d, "buffer_%s.gltf" % kind), "w") as f:
            json.dump(doc, f)


def main():
    d = sys.argv[1]
    os.makedirs(d, exist_ok=True)
    flat_obj(os.path.join(d, "flat.obj"))
    write_gltf(d)
    write_glb(d)
    write_3mf(d)
    write_dae(d)
    write_many_placements(d)
    write_bad_buffers(d)


if __name__ == "__main__":
    main()
