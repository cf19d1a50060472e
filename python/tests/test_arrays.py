# SPDX-License-Identifier: Apache-2.0
"""numpy in: dtypes, layouts, trimesh-like objects, bad arrays."""
import struct

import numpy as np
import pytest

import clvox


def octa_sphere(n=3):
    """A closed, outward icosphere-like mesh from an octahedron, float32-exact (no rounding
    between float64 and float32)."""
    v = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    f = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    v = [np.array(p, dtype=np.float64) for p in v]
    for _ in range(n):
        cache, nf = {}, []
        for a, b, c in f:
            def mid(i, j):
                k = (min(i, j), max(i, j))
                if k not in cache:
                    m = v[i] + v[j]
                    v.append(m / np.linalg.norm(m))
                    cache[k] = len(v) - 1
                return cache[k]
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
        f = nf
    verts = np.array(v, dtype=np.float32).astype(np.float64) * 2.0 + 0.25  # float32-exact
    return verts, np.array(f, dtype=np.int64)


def write_ply(path, v, f):
    with open(path, "wb") as fh:
        fh.write(b"ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\n"
                 b"property float y\nproperty float z\nelement face %d\nproperty list uchar int vertex_indices\n"
                 b"end_header\n" % (len(v), len(f)))
        fh.write(np.ascontiguousarray(v, dtype="<f4").tobytes())
        for a, b, c in f:
            fh.write(struct.pack("<Biii", 3, a, b, c))


V, F = octa_sphere()


def test_arrays_equal_cli_file(ctx, cli, tmp):
    ply = tmp / "s.ply"
    write_ply(ply, V, F)
    cli(ply, "-o", tmp / "s.exr", "-r", 40)
    ref = clvox.read(tmp / "s.exr")
    vol = ctx.voxelize((V, F), resolution=40)
    assert vol.report["closed"] and vol.report["triangles"] == len(F)
    assert np.array_equal(vol.occupancy, ref.occupancy)
    assert vol.origin == ref.origin


@pytest.mark.parametrize("vdtype", [np.float32, np.float64])
@pytest.mark.parametrize("fdtype", [np.int32, np.int64, np.uint32, np.uint16])
def test_dtypes(ctx, vdtype, fdtype):
    ref = ctx.voxelize((V.astype(np.float32), F.astype(np.uint32)), resolution=24)
    vol = ctx.voxelize((V.astype(vdtype), F.astype(fdtype)), resolution=24)
    assert np.array_equal(vol.occupancy, ref.occupancy)
    assert vol.occupancy.sum() > 0


def test_non_contiguous(ctx):
    ref = ctx.voxelize((V, F), resolution=24)
    vbig = np.zeros((len(V), 7), dtype=np.float64)
    vbig[:, 1:4] = V
    fbig = np.asfortranarray(np.repeat(F, 2, axis=0)[::2])
    assert not vbig[:, 1:4].flags.c_contiguous and not fbig.flags.c_contiguous
    vol = ctx.voxelize((vbig[:, 1:4], fbig), resolution=24)
    assert np.array_equal(vol.occupancy, ref.occupancy)


def test_trimesh_like_object_and_lists(ctx):
    class Obj:
        vertices = V
        faces = F
    ref = ctx.voxelize((V, F), resolution=20)
    assert np.array_equal(ctx.voxelize(Obj(), resolution=20).occupancy, ref.occupancy)
    assert np.array_equal(ctx.voxelize((V.tolist(), F.tolist()), resolution=20).occupancy, ref.occupancy)
    # real trimesh objects: test_trimesh.py (skipped, not silently passed, without trimesh)


def test_reused_mesh_object(ctx):
    m = ctx.mesh((V, F))
    assert m.report["closed"] and m.report["vertices"] == len(V)
    a = ctx.voxelize(m, resolution=16)
    b = ctx.voxelize(m, resolution=16)
    assert np.array_equal(a.occupancy, b.occupancy)


def test_float32_contiguous_not_copied():
    from clvox._core import _as_arrays
    v = np.ascontiguousarray(V, dtype=np.float32)
    f = np.ascontiguousarray(F, dtype=np.uint32)
    v2, f2 = _as_arrays(v, f)
    assert v2 is v and f2 is f


def test_bad_arrays(ctx):
    with pytest.raises(ValueError, match=r"vertices must have shape \(V, 3\)"):
        ctx.voxelize((V[:, :2], F))
    with pytest.raises(ValueError, match=r"faces must have shape \(F, 3\)"):
        ctx.voxelize((V, F[:, :2]))
    with pytest.raises(ValueError, match="negative vertex index -1"):
        ctx.voxelize((V, np.where(F == 0, -1, F)))
    with pytest.raises(ValueError, match="faces must be integer"):
        ctx.voxelize((V, F.astype(np.float64)))
    bad = F.copy()
    bad[3, 1] = len(V) + 5
    with pytest.raises(ValueError, match=f"references vertex {len(V) + 5}, but there are only {len(V)}") as e:
        ctx.voxelize((V, bad))
    assert isinstance(e.value, clvox.Error) and e.value.status_name == "mesh_invalid"
    assert e.value.status == 5
    nan = V.copy()
    nan[2, 1] = np.nan
    with pytest.raises(ValueError) as e:
        ctx.voxelize((nan, F))
    assert e.value.status_name == "mesh_invalid" and "finite" in e.value.message
    with pytest.raises(ValueError) as e:
        ctx.voxelize((V[:0], F[:0]))
    assert e.value.status_name in ("mesh_empty", "mesh_invalid", "invalid_argument")
    with pytest.raises(ValueError) as e:
        ctx.voxelize((V, F), resolution=100000)
    assert e.value.status_name == "grid"
    with pytest.raises(ValueError, match="method must be one of ray, tetra"):
        ctx.voxelize((V, F), method="bogus")
    with pytest.raises(TypeError):
        ctx.voxelize(42)


def test_inside_winding_and_parity(ctx):
    """The winding number (default) closes a hole and unions overlapping copies; parity does
    neither; the stats say what the preparation did."""
    v, f = octa_sphere(3)
    opened = f[1:]                      # one triangle removed: a hole
    win = ctx.voxelize((v, opened), resolution=24)
    par = ctx.voxelize((v, opened), resolution=24, inside="parity")
    full = ctx.voxelize((v, f), resolution=24)
    assert win.stats["inside"] == "winding" and par.stats["inside"] == "parity"
    assert win.stats["winding"]["holes"] == 1 and par.stats["winding"] is None
    assert np.array_equal(win.occupancy, full.occupancy)
    assert par.occupancy.sum() != full.occupancy.sum()
    # two copies, the second shifted: the union under winding, the XOR under parity
    v2 = np.concatenate([v, v + np.array([0.5, 0.0, 0.0])])
    f2 = np.concatenate([f, f + len(v)])
    box = (-2, -2, -2, 3, 3, 3)
    u = ctx.voxelize((v2, f2), dims=(20, 20, 20), box=box)
    a = ctx.voxelize((v, f), dims=(20, 20, 20), box=box).occupancy
    b = ctx.voxelize((v + np.array([0.5, 0.0, 0.0]), f), dims=(20, 20, 20), box=box).occupancy
    x = ctx.voxelize((v2, f2), dims=(20, 20, 20), box=box, inside="parity").occupancy
    assert np.array_equal(u.occupancy, a | b) and np.array_equal(x, a ^ b)
    with pytest.raises(ValueError):
        ctx.voxelize((v, f), resolution=8, inside="even")


def test_float_kernels(ctx):
    """float_kernels=True: the kernels without double precision give the default (winding) run's
    voxels on an open mesh, the centres float cannot settle decided on the host, and its coverage."""
    v, f = octa_sphere(4)
    open_f = f[::2].copy()  # every other face: an open mesh, w near 1/2 in places
    fk = clvox.Context(float_kernels=True)
    a = ctx.voxelize((v, open_f), resolution=24)
    b = fk.voxelize((v, open_f), resolution=24)
    assert np.array_equal(a.occupancy, b.occupancy)
    assert a.stats["winding"]["host_points"] == 0 and b.stats["winding"]["host_points"] >= 0
    # grey levels too (3x3 rays x 2 points, stochastic): the same coverage, bit for bit
    c = ctx.voxelize((v, open_f), resolution=16, oversample=(3, 2), stochastic=True, seed=5)
    d = fk.voxelize((v, open_f), resolution=16, oversample=(3, 2), stochastic=True, seed=5)
    assert np.array_equal(c.coverage, d.coverage) and c.coverage.dtype == np.float32
    # the device dicts say which build ran (kernels_float; the speed rule's ratio: 0 on a CPU)
    dev = ctx.device
    assert fk.device["kernels_float"]
    assert dev["kernels_float"] == (not dev["fp64"] or dev["fp64_slowdown"] >= 8)
    assert dev["type"] != "cpu" or dev["fp64_slowdown"] == 0.0


def test_soup_crack_weld(ctx):
    """A triangle soup (no shared vertex, corners jittered by 1e-5) goes through the certified
    crack weld, reported in the stats as --json has it; without jitter it merges back into the
    closed mesh (no weld needed)."""
    v, f = octa_sphere(4)
    soup_v = v[f.reshape(-1)].astype(np.float32)
    soup_f = np.arange(len(soup_v), dtype=np.uint32).reshape(-1, 3)
    rng = np.random.default_rng(7)
    jittered = soup_v + rng.uniform(-1e-5, 1e-5, soup_v.shape).astype(np.float32)
    s = ctx.voxelize((jittered, soup_f), resolution=24)
    cw = s.stats["winding"]["crack_weld"]
    assert cw is not None and cw["pairs"] > 0 and cw["holes_left"] == 0 and cw["distance"] > 0
    assert s.stats["winding"]["holes"] == len(f)  # the report is the soup's as given
    assert s.stats["winding"]["host_points"] == 0  # a double device decides every point itself
    closed = ctx.voxelize((v, f), resolution=24)
    assert closed.stats["winding"]["crack_weld"] is None
    plain = ctx.voxelize((soup_v, soup_f), resolution=24)
    assert plain.stats["winding"]["crack_weld"] is None and np.array_equal(plain.occupancy, closed.occupancy)
