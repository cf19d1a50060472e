# SPDX-License-Identifier: Apache-2.0
"""Scenes as input: a trimesh.Scene (two nodes placing one mesh, a third
placing another under a moved parent) and any object with .vertices/.faces
give the voxels of the same triangles flattened by hand. The scene test
without trimesh uses a stand-in with trimesh's .graph / .geometry interface;
the trimesh one is skipped when trimesh is not installed."""
import numpy as np
import pytest

CUBE_V = np.array([(x, y, z) for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=np.float64)
CUBE_F = np.array([(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4),
                   (2, 6, 3), (3, 6, 7), (0, 4, 2), (2, 4, 6), (1, 3, 5), (3, 7, 5)])
TET_V = np.array([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], dtype=np.float64)
TET_F = np.array([(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)])


def _m(scale, t):
    m = np.eye(4) * scale
    m[3, 3] = 1
    m[:3, 3] = t
    return m


PLACED = [("cube", _m(1, (0, 0, 0))), ("cube", _m(2, (3, 0.5, 0))), ("tet", _m(2, (3, 0.5, 2)))]
GEOM = {"cube": (CUBE_V, CUBE_F), "tet": (TET_V, TET_F)}


def _flat():
    vs, fs, base = [], [], 0
    for name, m in PLACED:
        v, f = GEOM[name]
        vs.append(v * m[0, 0] + m[:3, 3])
        fs.append(f + base)
        base += len(v)
    return np.concatenate(vs), np.concatenate(fs)


class _Obj:
    def __init__(self, v, f):
        self.vertices, self.faces = v, f


class _Graph:
    nodes_geometry = ["a", "b", "c", "line"]

    def __getitem__(self, node):
        if node == "line":
            return np.eye(4), "path"
        return {"a": PLACED[0], "b": PLACED[1], "c": PLACED[2]}[node][::-1]


class _Scene:
    graph = _Graph()
    geometry = {"cube": _Obj(CUBE_V, CUBE_F), "tet": _Obj(TET_V, TET_F), "path": object()}


def test_scene_like_object_flattened(ctx):
    ref = ctx.voxelize(_flat(), resolution=32)
    vol = ctx.voxelize(_Scene(), resolution=32)
    assert vol.dims == ref.dims and vol.origin == ref.origin
    assert np.array_equal(vol.occupancy, ref.occupancy) and ref.occupancy.sum() > 100
    assert vol.report["triangles"] == 28


def test_any_object_with_vertices_and_faces(ctx):
    v, f = _flat()
    ref = ctx.voxelize((v, f), resolution=24)
    assert np.array_equal(ctx.voxelize(_Obj(v, f), resolution=24).occupancy, ref.occupancy)


def test_trimesh_scene(ctx):
    trimesh = pytest.importorskip("trimesh")
    scene = trimesh.Scene()
    cube = trimesh.Trimesh(CUBE_V, CUBE_F, process=False)
    tet = trimesh.Trimesh(TET_V, TET_F, process=False)
    scene.add_geometry(cube, geom_name="cube", node_name="a", transform=PLACED[0][1])
    # a second node placing the same geometry (an instance, as trimesh.load makes for a glTF)
    scene.graph.update(frame_to="b", frame_from=scene.graph.base_frame, matrix=PLACED[1][1], geometry="cube")
    scene.add_geometry(tet, geom_name="tet", node_name="c", parent_node_name="b", transform=_m(1, (0, 0, 1)))
    assert len(scene.geometry) == 2                      # the cube is one geometry, placed twice
    ref = ctx.voxelize(_flat(), resolution=32)
    vol = ctx.voxelize(scene, resolution=32)
    assert vol.report["triangles"] == 28
    assert np.array_equal(vol.occupancy, ref.occupancy)
