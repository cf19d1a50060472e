# SPDX-License-Identifier: Apache-2.0
"""ctx.voxelize_to_file in every format: the CLI's files, byte for byte."""
import os
import signal
import threading
import time

import numpy as np
import pytest

import clvox
from conftest import DEFAULT

CUBE = (-1.2, -1.2, -1.2, 1.2, 1.2, 1.2)
CASES = [
    # (output name, python kwargs, CLI args)
    ("v.exr", dict(resolution=32), ["-r", 32]),
    ("v.exr", dict(resolution=24, oversample=2, compression="none"), ["-r", 24, "--oversample", 2,
                                                                      "--compression", "none"]),
    ("v.npy", dict(resolution=32), ["-r", 32]),
    ("v.npy", dict(resolution=30, npy_bits=True), ["-r", 30, "--npy-bits"]),
    ("v.npy", dict(resolution=24, oversample=3, channels="occupancy,coverage"),
     ["-r", 24, "--oversample", 3, "--channels", "occupancy,coverage"]),
    ("v.npy", dict(resolution=24, oversample=2, float32=True), ["-r", 24, "--oversample", 2, "--npy-float32"]),
    ("v.npy", dict(resolution=16, palette="paper46", uint32=True, float32=True),
     ["-r", 16, "--palette", "paper46", "--npy-uint32", "--npy-float32"]),
    ("v.NPY", dict(resolution=20, palette="paper46"), ["-r", 20, "--palette", "paper46"]),
    ("v.nrrd", dict(resolution=32), ["-r", 32]),
    ("v.nrrd", dict(resolution=24, oversample=2, compression="none"),
     ["-r", 24, "--oversample", 2, "--compression", "none"]),
    ("v.binvox", dict(resolution=32, box=CUBE), ["-r", 32, "--box", ",".join(map(str, CUBE))]),
    ("v.binvox", dict(resolution=24), ["-r", 24]),  # binvox's cube, by default in both
    ("v.binvox", dict(voxel_size=0.2, pad=1), ["--voxel-size", 0.2, "--pad", 1]),
    ("v.npy", dict(resolution=24, cube=True), ["-r", 24, "--cube"]),
    ("v.exr", dict(resolution=16, cube=True), ["-r", 16, "--cube"]),
    ("v.dat", dict(resolution=16, format="binvox"), ["-r", 16, "--format", "binvox"]),
    ("v.dat", dict(resolution=20, format="npy"), ["-r", 20, "--format", "npy"]),
    ("v.dat", dict(resolution=20, format="binvox", box=CUBE),
     ["-r", 20, "--format", "binvox", "--box", ",".join(map(str, CUBE))]),
]


def _files(d):
    return {n: open(os.path.join(d, n), "rb").read() for n in sorted(os.listdir(d))}


@pytest.mark.parametrize("name,kw,args", CASES, ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_file_equals_cli(ctx, cli, tmp, name, kw, args):
    a, b = tmp / "cli", tmp / "py"
    a.mkdir()
    b.mkdir()
    cli(DEFAULT, "-o", a / name, *args)
    stats = ctx.voxelize_to_file(DEFAULT, b / name, **kw)
    ref, mine = _files(a), _files(b)
    assert list(mine) == list(ref) and name in ref
    fmt = kw.get("format") or name.rsplit(".", 1)[1].lower()
    if fmt in ("npy", "nrrd"):
        channels = stats["channels"]
        assert len(ref) == len(channels) + (fmt == "npy")  # one file per channel (+ OUT.json)
    for n in ref:
        if fmt == "npy" and not n.endswith(".json"):
            x, y = np.load(a / n), np.load(b / n)
            assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), n
        assert mine[n] == ref[n], n  # and byte for byte: headers, sidecars, compression
    # the file holds what voxelize computes (one check per format; EXR also in test_cli_equal)
    vkw = {k: v for k, v in kw.items() if k not in ("format", "npy_bits", "float32", "uint32", "compression")}
    if fmt == "binvox" and "box" not in kw:
        vkw["cube"] = True  # what voxelize_to_file chose for binvox
    vol = ctx.voxelize(DEFAULT, **vkw)
    if kw.get("cube") or fmt == "binvox":
        assert vol.dims[0] == vol.dims[1] == vol.dims[2]
    main = name
    if fmt == "npy" and vol.occupancy is not None:
        arr = np.load(b / main)
        if kw.get("npy_bits"):
            arr = np.unpackbits(arr, axis=2, bitorder="little")[:, :, :vol.dims[0]]
        assert np.array_equal(arr.astype(bool), vol.occupancy)
    if fmt == "npy" and vol.element is not None:
        assert np.array_equal(np.load(b / main), vol.element)
    if fmt == "binvox":
        assert stats["filled_voxels"] == int(vol.occupancy.sum()) > 0


def test_cube(ctx, tmp):
    # a box 4 x 2 x 1 from the origin: the cube has edge 4 around its centre (2, 1, 0.5)
    v = np.array([[x, y, z] for z in (0, 1) for y in (0, 2) for x in (0, 4)], dtype=np.float32)
    f = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                  [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]])
    vol = ctx.voxelize((v, f), resolution=8, cube=True, pad=1)
    assert vol.dims == (10, 10, 10) and vol.voxel_size == (0.5, 0.5, 0.5)
    assert vol.origin == (-0.5, -1.5, -2.0)
    assert vol.occupancy.sum() == 8 * 4 * 2 and vol.occupancy[4:6, 3:7, 1:9].all()  # (Z, Y, X)
    assert ctx.voxelize((v, f), resolution=8).dims == (8, 4, 2)
    with clvox.Context() as c2:
        it = c2.iter_slabs(DEFAULT, resolution=20, cube=True)
        assert it.dims == (20, 20, 20)
        it.close()
    with pytest.raises(TypeError, match="cube must be True or False"):
        ctx.voxelize(DEFAULT, resolution=8, cube="yes")
    with pytest.raises(ValueError, match="a cubic grid needs equal dims"):
        ctx.voxelize(DEFAULT, dims=(8, 8, 6), cube=True)
    assert os.listdir(tmp) == []


def test_bad_extension_and_options_raise_value_error(ctx, tmp):
    with pytest.raises(ValueError, match=r"cannot tell the format of '.*x\.vox' from its extension") as e:
        ctx.voxelize_to_file(DEFAULT, tmp / "x.vox", resolution=8)
    assert isinstance(e.value, clvox.InvalidError) and e.value.status_name == "invalid_argument"
    with pytest.raises(ValueError, match="cannot tell the format"):
        ctx.voxelize_to_file(DEFAULT, tmp / "noext", resolution=8)
    with pytest.raises(ValueError, match="format must be one of"):
        ctx.voxelize_to_file(DEFAULT, tmp / "x.npy", resolution=8, format="png")
    with pytest.raises(ValueError, match="npy options"):
        ctx.voxelize_to_file(DEFAULT, tmp / "x.exr", resolution=8, npy_bits=True)
    with pytest.raises(ValueError, match="binvox holds no coverage"):
        ctx.voxelize_to_file(DEFAULT, tmp / "x.binvox", resolution=8, box=CUBE, oversample=2)
    with pytest.raises(ValueError, match="cubic"):
        ctx.voxelize_to_file(DEFAULT, tmp / "x.binvox", dims=(8, 8, 6))
    assert os.listdir(tmp) == []


@pytest.mark.parametrize("name", ["c.npy", "c.nrrd", "c.binvox", "c.exr"])
def test_cancel_leaves_no_file(ctx, tmp, name):
    kw = dict(box=CUBE) if name.endswith(".binvox") else dict(channels="occupancy,coverage", oversample=2)
    seen = []

    def stop(f):
        seen.append(f)
        return f < 0.3
    with pytest.raises(clvox.CancelledError):
        ctx.voxelize_to_file(DEFAULT, tmp / name, resolution=48, slab_depth=4, progress=stop, **kw)
    assert seen and seen[-1] >= 0.3 and seen[-1] < 1.0
    assert os.listdir(tmp) == []


@pytest.mark.parametrize("name", ["long.npy", "long.nrrd"])
def test_ctrl_c_leaves_no_file(ctx, tmp, name):
    assert threading.current_thread() is threading.main_thread()
    timer = threading.Timer(0.6, os.kill, (os.getpid(), signal.SIGINT))
    cpu0 = time.process_time()  # CPU, not wall time (see test_context.py)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            ctx.voxelize_to_file(DEFAULT, tmp / name, resolution=512, oversample=16,
                                 channels="occupancy,coverage")
    finally:
        timer.cancel()
    assert time.process_time() - cpu0 < 6
    assert os.listdir(tmp) == []
    assert ctx.voxelize(DEFAULT, resolution=8).occupancy.any()


READ_CASES = [
    # (file, voxelize kwargs, float32 coverage/score in the file)
    ("r.npy", dict(resolution=20), False),
    ("r.npy", dict(resolution=20, npy_bits=True), False),
    ("r.npy", dict(resolution=20, oversample=2, channels="occupancy,coverage"), False),
    ("r.npy", dict(resolution=20, oversample=2, float32=True), True),
    ("r.npy", dict(resolution=12, palette="planar10"), False),
    ("r.nrrd", dict(resolution=20, compression="none"), True),
    ("r.nrrd", dict(resolution=20, oversample=2, channels="occupancy,coverage"), True),
    ("r.nrrd", dict(resolution=12, palette="planar10"), True),
    ("r.binvox", dict(resolution=20, box=CUBE), False),
]


@pytest.mark.parametrize("name,kw,f32", READ_CASES, ids=[f"{c[0]}-{i}" for i, c in enumerate(READ_CASES)])
def test_read_every_format_equals_the_exr(ctx, tmp, name, kw, f32):
    """clvox.read of npy, NRRD and binvox gives the grid and voxels of the EXR of the same run
    (float32 coverage/score: equal once rounded to float16, the EXR's HALF)."""
    exr_kw = {k: v for k, v in kw.items() if k not in ("npy_bits", "float32", "compression")}
    ctx.voxelize_to_file(DEFAULT, tmp / "r.exr", **exr_kw)
    ctx.voxelize_to_file(DEFAULT, tmp / name, **kw)
    e, v = clvox.read(tmp / "r.exr"), clvox.read(tmp / name)
    assert v.dims == e.dims
    assert np.allclose(v.origin, e.origin, rtol=0, atol=1e-12) and np.allclose(v.voxel_size, e.voxel_size, rtol=1e-14)
    want = ["occupancy"] if name.endswith(".binvox") else e.channels
    assert v.channels == want
    for ch in want:
        a, b = getattr(v, ch), getattr(e, ch)
        if f32 and ch in ("coverage", "score"):
            a = a.astype(np.float16).astype(np.float32)
        assert np.array_equal(a, b), ch
