# SPDX-License-Identifier: Apache-2.0
"""Builds a Blender scene from `clvox instances` output by geometry instancing
(Cavagnino & Gribaudo, section 4: "a simple Blender script that reconstructs
the original object using geometry instancing"), saves it and renders it.

    blender -b --factory-startup --python scripts/tools/blender_instances.py -- \\
        --csv OUT.csv [--render-map MAP] [--objects LIB.blend] \\
        [--palette NAME|FILE] [--save OUT.blend] [--render OUT.png] \\
        [--size 160x120] [--samples 8]

Runs inside Blender (its own Python and bpy; tested with Debian 12's Blender
3.4), headless. What it makes:

- One *source object* per render object name (the CSV's `object` column, and
  every `object` line of --render-map), in the collection `clvox_sources`,
  which is excluded from the view layer (not rendered). A source is modelled
  in the centred unit cube [-1/2, 1/2]^3: the unit voxel with its centre at
  the origin.
  - From --objects LIB.blend: the mesh object named like the render object
    (appended; its mesh is used, its own transform is not), else a collection
    of that name (instanced as a whole).
  - Else a placeholder. With --palette (a built-in name or a palette file) it
    is the element's exact geometry: the convex cells of the basic element the
    object stands for (the first CSV row that uses it; frame `element`: that
    row's element, i.e. the basic element under S), clipped to the voxel; the
    complement of a one-cell element is cut into convex pieces; a complement
    of several cells gets the stand-in. Without --palette, or for an object
    no row uses, a stand-in: a primitive chosen from the object's name (cube,
    cone, cylinder, ico sphere, torus, UV sphere), 0.8 voxel wide and moved
    1/10 voxel towards +x +y so that a mirror or rotation shows. Every source
    gets a colour of its own, from its name.
- One *instance* per CSV row, in the collection `clvox_instances`, named
  `clvox_<row>` with the custom property `clvox_row` (0-based row): a linked
  duplicate sharing the source's mesh, or an empty instancing the source
  collection. Its matrix_world is the full 4x4
      translate(x, y, z) * diag(hx, hy, hz) * S      (frame basic)
      translate(x, y, z) * diag(hx, hy, hz)          (frame element)
  with S the CSV's signed permutation s00..s22 (a mirror when det S = -1;
  Blender keeps it as a negative scale).
- A camera looking at the instances' bounding box from the front right,
  above, framing it whole; a sun light and a dim world.
- --render OUT.png: a Cycles CPU render of --size (default 160x120) with
  --samples (default 8) samples, no denoising, 8-bit RGB PNG.
- --save OUT.blend: the scene (sources, instances, camera, light).

Outputs are written to a temporary name in their own directory and renamed
when everything succeeded, so a failed run leaves no file that looks valid;
an existing output that is not a regular file is refused. Errors are one line
on stderr, `blender_instances: error: ...` (CSV errors as `FILE:LINE: why`),
and the exit code is 1 (2 for bad arguments).
"""

import argparse
import colorsys
import csv
import math
import os
import sys
import time
import zlib

try:
    import bmesh
    import bpy
    from mathutils import Matrix, Vector
except ImportError:  # plain Python: only --help works
    bpy = None

PROG = "blender_instances"
HEADER = ["i", "j", "k", "x", "y", "z", "hx", "hy", "hz", "element", "name", "basic",
          "s00", "s01", "s02", "s10", "s11", "s12", "s20", "s21", "s22", "score", "object", "frame"]
NAME_CHARS = set("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-.")


class Failure(Exception):
    """A one-line error for the user."""


def fail(msg):
    raise Failure(msg)


def valid_name(s, longest=63):
    return 0 < len(s) <= longest and set(s) <= NAME_CHARS


# ---- arguments -----------------------------------------------------------------------

class Parser(argparse.ArgumentParser):
    def error(self, message):
        sys.stderr.write("%s: error: %s (see --help)\n" % (PROG, message))
        sys.exit(2)


def parse_args(argv):
    p = Parser(prog="blender -b --factory-startup --python scripts/tools/blender_instances.py --",
               description="Builds, saves and renders a Blender scene from `clvox instances` CSV.")
    p.add_argument("--csv", required=True, help="the CSV written by clvox instances")
    p.add_argument("--render-map", help="the render map the CSV was made with: its objects all get sources")
    p.add_argument("--objects", help="a .blend library: mesh objects or collections named like the render objects")
    p.add_argument("--palette", help="built-in palette name or palette file: exact placeholder geometry")
    p.add_argument("--save", help="write the scene to this .blend file")
    p.add_argument("--render", help="render to this PNG file (Cycles, CPU)")
    p.add_argument("--size", default="160x120", help="render size WxH (default 160x120)")
    p.add_argument("--samples", type=int, default=8, help="Cycles samples (default 8)")
    a = p.parse_args(argv)
    try:
        w, h = a.size.lower().split("x")
        a.width, a.height = int(w), int(h)
    except ValueError:
        p.error("--size '%s': expected WxH, e.g. 160x120" % a.size)
    if not (1 <= a.width <= 8192 and 1 <= a.height <= 8192):
        p.error("--size '%s': 1 to 8192 pixels per side" % a.size)
    if not 1 <= a.samples <= 4096:
        p.error("--samples %d: 1 to 4096" % a.samples)
    if not a.save and not a.render:
        p.error("nothing to do: give --save OUT.blend and/or --render OUT.png")
    return a


# ---- inputs -----------------------------------------------------------------------------

def read_rows(path):
    """The CSV's rows as dicts of typed values."""
    try:
        f = open(path, newline="")
    except OSError as e:
        fail("cannot open '%s': %s" % (path, e.strerror))
    rows = []
    with f:
        reader = csv.reader(f)
        try:
            header = next(reader, None)
            if header != HEADER:
                fail("%s:1: not a `clvox instances` table (expected the header %s)" % (path, ",".join(HEADER)))
            for line, rec in enumerate(reader, start=2):
                if len(rec) != len(HEADER):
                    fail("%s:%d: %d fields, expected %d" % (path, line, len(rec), len(HEADER)))
                r = dict(zip(HEADER, rec))
                try:
                    v = {k: int(r[k]) for k in ("i", "j", "k", "element")}
                    v.update({k: float(r[k]) for k in ("x", "y", "z", "hx", "hy", "hz", "score")})
                    s = [int(r[k]) for k in HEADER[12:21]]
                except ValueError:
                    fail("%s:%d: a field is not a number" % (path, line))
                if not all(math.isfinite(v[k]) for k in ("x", "y", "z", "hx", "hy", "hz")) or \
                        min(v["hx"], v["hy"], v["hz"]) <= 0:
                    fail("%s:%d: position or voxel size not finite and positive" % (path, line))
                if sorted(abs(t) for t in s) != [0, 0, 0, 0, 0, 0, 1, 1, 1] or \
                        any(sum(abs(s[3 * i + j]) for j in range(3)) != 1 for i in range(3)) or \
                        any(sum(abs(s[3 * i + j]) for i in range(3)) != 1 for j in range(3)):
                    fail("%s:%d: s00..s22 is not a signed permutation" % (path, line))
                for k in ("name", "basic", "object"):
                    if not valid_name(r[k]):
                        fail("%s:%d: bad %s '%s'" % (path, line, k, r[k][:64]))
                if r["frame"] not in ("basic", "element"):
                    fail("%s:%d: frame '%s' is neither basic nor element" % (path, line, r["frame"][:64]))
                v.update(name=r["name"], basic=r["basic"], object=r["object"], frame=r["frame"], s=s, line=line)
                rows.append(v)
        except csv.Error as e:
            fail("%s:%d: %s" % (path, reader.line_num, e))
        except UnicodeDecodeError:
            fail("%s: not a text file" % path)
    return rows


def read_map_objects(path):
    """Object names of a render map, in order (the map was checked by clvox)."""
    names = []
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for line, text in enumerate(f, start=1):
                t = text.split("#", 1)[0].split()
                if len(t) == 3 and t[0] == "object":
                    if not valid_name(t[1]):
                        fail("%s:%d: bad object name '%s'" % (path, line, t[1][:64]))
                    if t[1] not in names:
                        names.append(t[1])
    except OSError as e:
        fail("cannot open render map '%s': %s" % (path, e.strerror))
    return names


# Basic elements of the built-in palettes (docs/design.md "Palettes"): cells of
# half-spaces (a, b, c, d): a x + b y + c z <= d in the unit voxel.
BUILTIN = {
    "full": [[]],
    "wedge": [[(1, 1, 0, 1)]],
    "roof": [[(-2, 0, 1, 0), (2, 0, 1, 2)]],
    "column": [[(1, 0, 0, 0.5), (0, 1, 0, 0.5)]],
    "corner": [[(1, 1, 1, 1)]],
    "half_x_lo": [[(1, 0, 0, 0.5)]],
    "diag_00": [[(1, 1, 0, 1)]],
}
BUILTIN_PALETTES = {
    "binary": ["full"],
    "planar10": ["full", "half_x_lo", "diag_00"],
    "paper46": ["full", "wedge", "roof", "column", "corner"],
    "paper78": ["full", "wedge", "roof", "column", "corner"],
}


def read_palette(arg):
    """{basic element name: (cells, complement)} for --palette."""
    if arg in BUILTIN_PALETTES:
        shapes = {n: (BUILTIN[n], False) for n in BUILTIN_PALETTES[arg]}
        if arg == "paper78":  # the complements' basic elements
            for n in ("roof", "column", "corner"):
                shapes["not_" + n] = (BUILTIN[n], True)
        return shapes
    shapes, cur = {}, None
    try:
        with open(arg, encoding="utf-8", errors="replace") as f:
            for line, text in enumerate(f, start=1):
                t = text.split("#", 1)[0].split()
                if not t:
                    continue
                if t[0] == "element" and len(t) == 2:
                    cur = (t[1], [], [False])
                elif t[0] == "cell" and cur:
                    cur[1].append([])
                elif t[0] == "complement" and cur:
                    cur[2][0] = True
                elif t[0] == "end" and cur:
                    shapes[cur[0]] = (cur[1], cur[2][0])
                    cur = None
                elif len(t) == 4 and cur and cur[1]:
                    try:
                        cur[1][-1].append(tuple(float(x) for x in t))
                    except ValueError:
                        fail("%s:%d: not a half-space" % (arg, line))
                elif t[0] != "symmetry":
                    fail("%s:%d: not a palette file line (check it with clvox palette show)" % (arg, line))
    except OSError as e:
        fail("cannot open palette '%s': %s" % (arg, e.strerror))
    shapes.setdefault("full", ([[]], False))
    return shapes


# ---- geometry ---------------------------------------------------------------------------

CUBE = [(-1, 0, 0, 0), (1, 0, 0, 1), (0, -1, 0, 0), (0, 1, 0, 1), (0, 0, -1, 0), (0, 0, 1, 1)]


def solve3(p, q, r):
    (a1, b1, c1, d1), (a2, b2, c2, d2), (a3, b3, c3, d3) = p, q, r
    det = a1 * (b2 * c3 - b3 * c2) - b1 * (a2 * c3 - a3 * c2) + c1 * (a2 * b3 - a3 * b2)
    if abs(det) < 1e-12:
        return None
    x = (d1 * (b2 * c3 - b3 * c2) - b1 * (d2 * c3 - d3 * c2) + c1 * (d2 * b3 - d3 * b2)) / det
    y = (a1 * (d2 * c3 - d3 * c2) - d1 * (a2 * c3 - a3 * c2) + c1 * (a2 * d3 - a3 * d2)) / det
    z = (a1 * (b2 * d3 - b3 * d2) - b1 * (a2 * d3 - a3 * d2) + d1 * (a2 * b3 - a3 * b2)) / det
    return (x, y, z)


def convex_vertices(planes):
    """Vertices of the convex cell {p in [0,1]^3 : every plane}, centred on the voxel."""
    hs = list(planes) + CUBE
    pts = []
    for i in range(len(hs)):
        for j in range(i + 1, len(hs)):
            for k in range(j + 1, len(hs)):
                p = solve3(hs[i], hs[j], hs[k])
                if p and all(a * p[0] + b * p[1] + c * p[2] <= d + 1e-9 for a, b, c, d in hs):
                    q = tuple(round(t - 0.5, 9) for t in p)
                    if q not in pts:
                        pts.append(q)
    return pts


def element_pieces(cells, complement):
    """Convex pieces (vertex lists) of an element, or None when only a stand-in will do."""
    if not complement:
        return [v for v in (convex_vertices(c) for c in cells) if len(v) >= 4]
    if len(cells) != 1:
        return None
    # cube minus one convex cell = the disjoint convex pieces
    # {violates plane i, satisfies planes 0..i-1}
    pieces, cell = [], cells[0]
    for i, (a, b, c, d) in enumerate(cell):
        v = convex_vertices([(-a, -b, -c, -d)] + list(cell[:i]))
        if len(v) >= 4:
            pieces.append(v)
    return pieces


def hull_mesh(name, pieces, s=None):
    """A mesh of the convex hulls of the pieces (vertices mapped by S when given)."""
    me = bpy.data.meshes.new(name)
    bm = bmesh.new()
    for piece in pieces:
        verts = []
        for p in piece:
            if s:
                p = tuple(sum(s[3 * r + c] * p[c] for c in range(3)) for r in range(3))
            verts.append(bm.verts.new(p))
        res = bmesh.ops.convex_hull(bm, input=verts)
        unused = [g for g in res["geom_interior"] + res["geom_unused"] if isinstance(g, bmesh.types.BMVert)]
        if unused:
            bmesh.ops.delete(bm, geom=unused, context="VERTS")
    bm.to_mesh(me)
    bm.free()
    return me


STANDINS = ["cube", "cone", "cylinder", "ico_sphere", "torus", "uv_sphere"]


def standin_mesh(name):
    """A primitive chosen from the name, 0.8 voxel wide, moved 0.1 towards +x +y."""
    kind = STANDINS[zlib.crc32(name.encode()) % len(STANDINS)]
    me = bpy.data.meshes.new(name)
    bm = bmesh.new()
    if kind == "cube":
        bmesh.ops.create_cube(bm, size=0.8)
    elif kind == "cone":
        bmesh.ops.create_cone(bm, cap_ends=True, segments=16, radius1=0.4, radius2=0.0, depth=0.8)
    elif kind == "cylinder":
        bmesh.ops.create_cone(bm, cap_ends=True, segments=16, radius1=0.4, radius2=0.4, depth=0.8)
    elif kind == "ico_sphere":
        bmesh.ops.create_icosphere(bm, subdivisions=2, radius=0.4)
    elif kind == "torus":  # a ring of small spheres: bmesh has no torus
        for t in range(12):
            a = 2 * math.pi * t / 12
            bmesh.ops.create_icosphere(bm, subdivisions=1, radius=0.12,
                                       matrix=Matrix.Translation((0.28 * math.cos(a), 0.28 * math.sin(a), 0)))
    else:
        bmesh.ops.create_uvsphere(bm, u_segments=16, v_segments=8, radius=0.4)
    bmesh.ops.translate(bm, verts=bm.verts, vec=(0.1, 0.1, 0.0))
    bm.to_mesh(me)
    bm.free()
    return me, kind


def colour_material(name):
    h = zlib.crc32(name.encode()) / 2.0 ** 32
    r, g, b = colorsys.hsv_to_rgb(h, 0.6, 0.85)
    mat = bpy.data.materials.new("clvox_" + name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    if bsdf:
        bsdf.inputs["Base Color"].default_value = (r, g, b, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.6
    mat.diffuse_color = (r, g, b, 1.0)
    return mat


# ---- outputs ----------------------------------------------------------------------------

def check_output(path):
    if os.path.lexists(path) and not (os.path.isfile(path) and not os.path.islink(path)):
        fail("cannot write '%s': it is not a regular file" % path)
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d) or not os.access(d, os.W_OK | os.X_OK):
        fail("cannot write '%s': directory '%s' is missing or not writable" % (path, d))


def temp_name(path, ext):
    d, base = os.path.split(os.path.abspath(path))
    return os.path.join(d, ".%s.%d.tmp%s" % (base, os.getpid(), ext))


# ---- the scene --------------------------------------------------------------------------

def build(args, rows):
    scene = bpy.context.scene
    for ob in list(bpy.data.objects):  # the factory scene's cube, camera and light
        bpy.data.objects.remove(ob, do_unlink=True)
    src_coll = bpy.data.collections.new("clvox_sources")
    inst_coll = bpy.data.collections.new("clvox_instances")
    scene.collection.children.link(src_coll)
    scene.collection.children.link(inst_coll)
    bpy.context.view_layer.layer_collection.children["clvox_sources"].exclude = True

    names = []
    for r in rows:
        if r["object"] not in names:
            names.append(r["object"])
    if args.render_map:
        for n in read_map_objects(args.render_map):
            if n not in names:
                names.append(n)
    first_use = {}
    for r in rows:
        first_use.setdefault(r["object"], r)

    library = {}
    if args.objects:
        if not os.path.isfile(args.objects):
            fail("cannot open library '%s'" % args.objects)
        try:
            with bpy.data.libraries.load(os.path.abspath(args.objects), link=False) as (src, dst):
                have_obj, have_coll = set(src.objects), set(src.collections)
                dst.objects = [n for n in names if n in have_obj]
                dst.collections = [n for n in names if n not in have_obj and n in have_coll]
        except (OSError, RuntimeError) as e:
            fail("cannot read library '%s': %s" % (args.objects, str(e).splitlines()[0] if str(e) else "error"))
        for ob in dst.objects:
            if ob is None:
                continue
            if ob.type != "MESH":
                fail("library '%s': object '%s' is a %s, not a mesh (put it in a collection named '%s')"
                     % (args.objects, ob.name, ob.type.lower(), ob.name))
            library[ob.name] = ("mesh", ob.data)
        for co in dst.collections:
            if co is not None:
                library[co.name] = ("collection", co)
    shapes = read_palette(args.palette) if args.palette else None

    sources, made = {}, {"library": 0, "exact": 0, "stand-in": 0}
    for n in names:
        if n in library:
            kind, data = library[n]
            made["library"] += 1
            if kind == "collection":
                sources[n] = ("collection", data)
                continue
            me = data
        else:
            me, r = None, first_use.get(n)
            if shapes is not None and r is not None and r["basic"] in shapes:
                pieces = element_pieces(*shapes[r["basic"]])
                if pieces:
                    me = hull_mesh(n, pieces, r["s"] if r["frame"] == "element" else None)
                    made["exact"] += 1
            if me is None:
                me, _ = standin_mesh(n)
                made["stand-in"] += 1
            me.materials.append(colour_material(n))
        src = bpy.data.objects.new("clvox_src_" + n, me)
        src_coll.objects.link(src)
        sources[n] = ("mesh", me)

    lo = [math.inf] * 3
    hi = [-math.inf] * 3
    for idx, r in enumerate(rows):
        h = (r["hx"], r["hy"], r["hz"])
        s = r["s"] if r["frame"] == "basic" else [1, 0, 0, 0, 1, 0, 0, 0, 1]
        c = (r["x"], r["y"], r["z"])
        m = Matrix([[h[i] * s[3 * i + j] for j in range(3)] + [c[i]] for i in range(3)] + [[0, 0, 0, 1]])
        kind, data = sources[r["object"]]
        if kind == "mesh":
            ob = bpy.data.objects.new("clvox_%06d" % idx, data)
        else:
            ob = bpy.data.objects.new("clvox_%06d" % idx, None)
            ob.instance_type = "COLLECTION"
            ob.instance_collection = data
        ob.rotation_mode = "QUATERNION"
        ob.matrix_world = m
        ob["clvox_row"] = idx
        inst_coll.objects.link(ob)
        for i in range(3):
            lo[i] = min(lo[i], c[i] - h[i] / 2)
            hi[i] = max(hi[i], c[i] + h[i] / 2)
    if not rows:
        lo, hi = [-0.5] * 3, [0.5] * 3

    # camera: from the front right, above, the bounding sphere in view
    centre = Vector([(lo[i] + hi[i]) / 2 for i in range(3)])
    radius = max(0.5 * (Vector(hi) - Vector(lo)).length, 1e-6)
    cam_data = bpy.data.cameras.new("clvox_camera")
    cam_data.lens = 50.0
    cam = bpy.data.objects.new("clvox_camera", cam_data)
    scene.collection.objects.link(cam)
    scene.render.resolution_x, scene.render.resolution_y = args.width, args.height
    scene.render.resolution_percentage = 100
    # sensor fit AUTO: the sensor width spans the longer side; the shorter one limits the view
    aspect = args.width / args.height
    fov_long = 2 * math.atan(cam_data.sensor_width / (2 * cam_data.lens))
    fov = 2 * math.atan(math.tan(fov_long / 2) / max(aspect, 1 / aspect))
    dist = radius / math.sin(fov / 2) * 1.05
    direction = Vector((1.0, -1.4, 0.9)).normalized()
    cam.location = centre + direction * dist
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = (-direction).to_track_quat("-Z", "Y")
    cam_data.clip_start = max(dist - radius, dist * 1e-3) * 0.5
    cam_data.clip_end = (dist + radius) * 2
    scene.camera = cam

    sun_data = bpy.data.lights.new("clvox_sun", type="SUN")
    sun_data.energy = 3.0
    sun_data.angle = math.radians(10)
    sun = bpy.data.objects.new("clvox_sun", sun_data)
    sun.rotation_mode = "QUATERNION"
    sun.rotation_quaternion = (-Vector((0.4, -0.6, 1.0)).normalized()).to_track_quat("-Z", "Y")
    scene.collection.objects.link(sun)
    world = scene.world or bpy.data.worlds.new("clvox_world")
    scene.world = world
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    if bg:
        bg.inputs["Color"].default_value = (0.05, 0.06, 0.09, 1.0)
        bg.inputs["Strength"].default_value = 1.0
    return made, len(names)


def render(args, path):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = args.samples
    scene.cycles.use_denoising = False
    scene.render.film_transparent = False
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.color_depth = "8"
    scene.render.use_file_extension = False
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    if not os.path.isfile(path) or os.path.getsize(path) == 0:
        fail("the render wrote no picture")


def main(argv):
    args = parse_args(argv)
    if bpy is None:
        fail("run inside Blender: blender -b --factory-startup --python scripts/tools/blender_instances.py -- ...")
    for out in (args.save, args.render):
        if out:
            check_output(out)
    start = time.time()
    rows = read_rows(args.csv)
    made, nsrc = build(args, rows)
    temps = []
    try:
        if args.render:
            t = temp_name(args.render, ".png")
            temps.append((t, args.render))
            render(args, t)
        if args.save:
            t = temp_name(args.save, ".blend")
            temps.append((t, args.save))
            res = bpy.ops.wm.save_as_mainfile(filepath=t, check_existing=False, copy=True, compress=False)
            if "FINISHED" not in res or not os.path.isfile(t):
                fail("saving '%s' failed" % args.save)
        for t, out in temps:
            check_output(out)
            os.replace(t, out)
    finally:
        for t, _ in temps:
            if os.path.lexists(t):
                os.unlink(t)
    print("%s: %d instances of %d objects (%d from the library, %d exact, %d stand-ins)%s%s in %.1f s"
          % (PROG, len(rows), nsrc, made["library"], made["exact"], made["stand-in"],
             ", saved " + args.save if args.save else "",
             ", rendered %s (%dx%d, %d samples)" % (args.render, args.width, args.height, args.samples)
             if args.render else "", time.time() - start))


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else ([] if bpy else sys.argv[1:])
    try:
        main(argv)
    except Failure as e:
        sys.stderr.write("%s: error: %s\n" % (PROG, str(e).replace("\n", " | ")))
        sys.stderr.flush()
        sys.exit(1)
    except Exception as e:  # Blender exits 0 after an uncaught exception: say so and fail
        import traceback
        traceback.print_exc()
        sys.stderr.write("%s: error: internal error: %s: %s\n"
                         % (PROG, type(e).__name__, str(e).splitlines()[0] if str(e) else ""))
        sys.stderr.flush()
        sys.exit(1)
