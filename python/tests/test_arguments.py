# SPDX-License-Identifier: Apache-2.0
"""Numeric arguments are checked in Python, naming the argument: ValueError for a bad
value (not cffi's OverflowError, not a silent default or truncation), TypeError for a
wrong type (bool and float are not integers); numpy numbers are accepted. Messages from
the library name Python arguments, not CLI flags (issue 32, defect 11)."""
import os

import numpy as np
import pytest

import clvox
from conftest import DEFAULT

BAD = [  # (keyword arguments, exception, the argument the message must name)
    (dict(resolution=-1), ValueError, "resolution"),
    (dict(resolution=0), ValueError, "resolution"),
    (dict(resolution=2 ** 32), ValueError, "resolution"),
    (dict(resolution=32.5), TypeError, "resolution"),
    (dict(resolution=32.0), TypeError, "resolution"),
    (dict(resolution=True), TypeError, "resolution"),
    (dict(resolution="32"), TypeError, "resolution"),
    (dict(dims=(-1, 8, 8)), ValueError, "dims"),
    (dict(dims=(0, 8, 8)), ValueError, "dims"),
    (dict(dims=(8, 8)), ValueError, "dims"),
    (dict(dims=(8, 8, 8.5)), TypeError, "dims"),
    (dict(dims=(True, 8, 8)), TypeError, "dims"),
    (dict(dims=8), TypeError, "dims"),
    (dict(pad=-1), ValueError, "pad"),
    (dict(pad=1.5), TypeError, "pad"),
    (dict(pad=True), TypeError, "pad"),
    (dict(seed=-1), ValueError, "seed"),
    (dict(seed=2 ** 64), ValueError, "seed"),
    (dict(seed=1.5), TypeError, "seed"),
    (dict(voxel_size=0), ValueError, "voxel_size"),
    (dict(voxel_size=-0.1), ValueError, "voxel_size"),
    (dict(voxel_size=float("nan")), ValueError, "voxel_size"),
    (dict(voxel_size=(0.1, 0.1)), ValueError, "voxel_size"),
    (dict(voxel_size=True), TypeError, "voxel_size"),
    (dict(box=(0, 0, 0, 1, 1)), ValueError, "box"),
    (dict(box=(0, 0, 0, 1, float("inf"), 1)), ValueError, "box"),
    (dict(box=(0, 0, 0, 1, -1, 1)), ValueError, "box"),
    (dict(resolution=8, dims=(8, 8, 8)), ValueError, "dims"),
    (dict(resolution=8, voxel_size=0.1), ValueError, "voxel_size"),
    (dict(oversample=0), ValueError, "oversample"),
    (dict(oversample=-2), ValueError, "oversample"),
    (dict(oversample=2.5), TypeError, "oversample"),
    (dict(oversample=(2, -1)), ValueError, "oversample"),
    (dict(threshold=1.5), ValueError, "threshold"),
    (dict(threshold=float("nan")), ValueError, "threshold"),
    (dict(threshold=True), TypeError, "threshold"),
    (dict(weld=-1.0), ValueError, "weld"),
    (dict(slab_depth=-1), ValueError, "slab_depth"),
    (dict(slab_depth=2.5), TypeError, "slab_depth"),
    (dict(depth=-1), ValueError, "depth"),
    (dict(leaf=-1), ValueError, "leaf"),
    (dict(threads=-1), ValueError, "threads"),
    (dict(threads=1.5), TypeError, "threads"),
    (dict(progress=5), TypeError, "progress"),
]


@pytest.mark.parametrize("kw,exc,name", BAD, ids=[repr(b[0]) for b in BAD])
def test_bad_numbers_name_the_argument(ctx, tmp, kw, exc, name):
    with pytest.raises(exc, match=name):
        ctx.voxelize(DEFAULT, **kw)
    with pytest.raises(exc, match=name):
        ctx.voxelize_to_file(DEFAULT, tmp / "v.exr", **kw)
    assert os.listdir(tmp) == []
    with pytest.raises(exc, match=name):
        ctx.iter_slabs(DEFAULT, **kw)
    assert ctx.voxelize(DEFAULT, resolution=8).occupancy.any()  # the Context is free


def test_prefetch_and_device(ctx):
    with pytest.raises(ValueError, match="prefetch"):
        ctx.iter_slabs(DEFAULT, resolution=8, prefetch=0)
    with pytest.raises(TypeError, match="prefetch"):
        ctx.iter_slabs(DEFAULT, resolution=8, prefetch=1.5)
    with pytest.raises(ValueError, match="device"):
        clvox.Context(device=-1)
    with pytest.raises(TypeError, match="device"):
        clvox.Context(device=True)
    assert ctx.voxelize(DEFAULT, resolution=8).occupancy.any()


def test_numpy_numbers_accepted(ctx):
    ref = ctx.voxelize(DEFAULT, resolution=16, pad=1)
    v = ctx.voxelize(DEFAULT, resolution=np.int32(16), pad=np.uint8(1))
    assert np.array_equal(v.occupancy, ref.occupancy)
    d = ctx.voxelize(DEFAULT, dims=np.array([16, 12, 8]), box=np.array([[-1, -1, -1], [1, 1, 1]]), pad=np.int64(0))
    assert d.dims == (16, 12, 8) and d.origin == (-1, -1, -1)
    s = ctx.voxelize(DEFAULT, voxel_size=np.float32(ref.voxel_size[0]), oversample=np.int64(2),
                     seed=np.uint64(2 ** 63), stochastic=True, threshold=np.float64(0.5), slab_depth=np.int16(3))
    assert s.occupancy.any() and s.stats["samples_per_voxel"] > 1
    assert sum(x.nz for x in ctx.iter_slabs(DEFAULT, resolution=np.int64(16), prefetch=np.int8(2))) == ref.dims[2] - 2


def test_library_messages_name_python_arguments(ctx, tmp):
    cases = [
        (lambda: ctx.voxelize(DEFAULT, box=(1, 1, 1, 1, 1, 1)), "give box=, dims= or voxel_size="),
        (lambda: ctx.voxelize(DEFAULT, method="tetra", inside="winding"), "inside='parity'"),
        (lambda: ctx.voxelize_to_file(DEFAULT, tmp / "v.npy", resolution=8, compression="rle"), "compression="),
        (lambda: ctx.voxelize_to_file(DEFAULT, tmp / "v.binvox", dims=(8, 8, 6)), "cube=True"),
        (lambda: clvox.Context(device="no-such-device-xyz"), "clvox.devices()"),
    ]
    for call, words in cases:
        with pytest.raises(clvox.Error) as e:
            call()
        assert words in str(e.value) and "--" not in str(e.value), str(e.value)
    assert os.listdir(tmp) == []
