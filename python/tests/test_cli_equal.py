# SPDX-License-Identifier: Apache-2.0
"""Python results equal the CLI's EXR voxel for voxel."""
import numpy as np
import pytest

import clvox
from conftest import DEFAULT, mesh_path

CASES = [
    # (mesh, python kwargs, CLI args)
    ("default", dict(resolution=48), ["-r", 48]),
    ("default", dict(resolution=40, method="tetra"), ["-r", 40, "--method", "tetra"]),
    ("default", dict(dims=(20, 30, 17), pad=2), ["--dims", "20,30,17", "--pad", 2]),
    ("default", dict(voxel_size=0.07, box=(-1, -1, -0.5, 1.2, 1, 0.6)),
     ["--voxel-size", 0.07, "--box", "-1,-1,-0.5,1.2,1,0.6"]),
    ("default", dict(resolution=32, oversample=3), ["-r", 32, "--oversample", 3]),
    ("default", dict(resolution=32, oversample=(2, 5), stochastic=True, seed=7),
     ["-r", 32, "--oversample", "2,5", "--stochastic", "--seed", 7]),
    ("default", dict(resolution=32, oversample=2, channels="occupancy,coverage", threshold=0.3),
     ["-r", 32, "--oversample", 2, "--channels", "occupancy,coverage", "--threshold", 0.3]),
    ("default", dict(resolution=40, mode="surface"), ["-r", 40, "--mode", "surface"]),
    ("default", dict(resolution=40, mode="conservative", axis="z"), ["-r", 40, "--mode", "conservative", "--axis", "z"]),
    ("default", dict(resolution=20, palette="paper46"), ["-r", 20, "--palette", "paper46"]),
    ("cow.off", dict(resolution=24, palette="paper78", metric="inner", oversample=(3, 4)),
     ["-r", 24, "--palette", "paper78", "--metric", "inner", "--samples", "9,4"]),
    ("armadillo.off", dict(resolution=64), ["-r", 64]),
    ("bunny00.off", dict(resolution=50, method="tetra"), ["-r", 50, "--method", "tetra"]),
    ("camel.off", dict(resolution=40, oversample=2, axis="y"), ["-r", 40, "--oversample", 2, "--axis", "y"]),
]


def _half(x):
    return np.asarray(x, dtype=np.float64).astype(np.float16).astype(np.float32)


@pytest.mark.parametrize("name,kw,args", CASES, ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_equals_cli(ctx, cli, tmp, name, kw, args):
    path = DEFAULT if name == "default" else mesh_path(name)
    out = tmp / "cli.exr"
    cli(path, "-o", out, *args)
    ref = clvox.read(out)
    vol = ctx.voxelize(path, **kw)
    assert vol.dims == ref.dims
    assert np.allclose(vol.origin, ref.origin, rtol=0, atol=0)
    assert vol.voxel_size == ref.voxel_size
    assert sorted(vol.channels) == sorted(ref.channels)
    assert vol.shape == (vol.dims[2], vol.dims[1], vol.dims[0])
    if ref.occupancy is not None:
        assert vol.occupancy.dtype == np.bool_ and vol.occupancy.shape == vol.shape
        assert np.array_equal(vol.occupancy, ref.occupancy)
        assert int(vol.occupancy.sum()) == vol.stats["filled_voxels"] or ref.coverage is not None
    if ref.coverage is not None:
        assert vol.coverage.dtype == np.float32
        # the file holds HALF; the array the exact count/samples
        samples = vol.stats["samples_per_voxel"]
        counts = np.rint(vol.coverage.astype(np.float64) * samples)
        assert np.array_equal(_half(counts / samples), ref.coverage)
    if ref.element is not None:
        assert vol.element.dtype == np.uint16
        assert np.array_equal(vol.element, ref.element)
        assert np.array_equal(_half(vol.score), ref.score)
    # and the library's own file from Python is the CLI's file, voxel for voxel
    mine = tmp / "py.exr"
    ctx.voxelize_to_file(path, mine, **kw)
    again = clvox.read(mine)
    for c in ref.channels:
        assert np.array_equal(getattr(again, c), getattr(ref, c)), c


def test_slab_iterator_equals_voxelize(ctx):
    full = ctx.voxelize(DEFAULT, resolution=40, oversample=2, channels=["occupancy", "coverage"])
    it = ctx.iter_slabs(DEFAULT, resolution=40, oversample=2, channels=["occupancy", "coverage"], slab_depth=7)
    assert it.dims == full.dims
    z = 0
    for s in it:
        assert s.z0 == z and s.occupancy.shape == (s.nz, full.dims[1], full.dims[0])
        assert np.array_equal(s.occupancy, full.occupancy[z:z + s.nz])
        assert np.array_equal(s.coverage, full.coverage[z:z + s.nz])
        z += s.nz
    assert z == full.dims[2]
    assert it.stats["filled_voxels"] == full.stats["filled_voxels"]


def test_slab_iterator_break_cancels_and_frees_context(ctx):
    it = ctx.iter_slabs(DEFAULT, resolution=64, slab_depth=4)
    first = next(it)
    assert first.z0 == 0
    with pytest.raises(RuntimeError, match="running another call"):
        ctx.voxelize(DEFAULT, resolution=8)
    it.close()
    assert ctx.voxelize(DEFAULT, resolution=8).occupancy.any()


def test_read_channels_and_info(ctx, tmp):
    out = tmp / "v.exr"
    ctx.voxelize_to_file(DEFAULT, out, resolution=24, palette="paper46", channels="element,score,coverage")
    info = clvox.read_info(out)
    assert info["palette"] == "paper46" and info["dims"][0] == 24
    assert sorted(info["channels"]) == ["coverage", "element", "score"]
    v = clvox.read(out, channels="element")
    assert v.channels == ["element"] and v.element.max() >= 2
    with pytest.raises(ValueError, match="no channel 'occupancy'"):
        clvox.read(out, channels="occupancy")


def test_to_world_index_of(ctx):
    v = ctx.voxelize(DEFAULT, resolution=32, pad=1)
    idx = np.argwhere(v.occupancy)
    pts = v.to_world(idx)
    assert np.array_equal(v.index_of(pts), idx)
    assert np.allclose(pts[0], np.asarray(v.origin) + (idx[0][::-1] + 0.5) * np.asarray(v.voxel_size))
    # the corner of voxel (0,0,0) belongs to it; the grid's far corner is outside
    assert v.index_of(v.origin).tolist() == [0, 0, 0]
