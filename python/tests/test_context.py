# SPDX-License-Identifier: Apache-2.0
"""Context reuse, errors, cancel, Ctrl-C, progress."""
import os
import signal
import threading
import time

import numpy as np
import pytest

import clvox
from conftest import DEFAULT
from test_arrays import F, V


def rss_kib():
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024


def test_devices_and_context(ctx):
    devs = clvox.devices()
    assert devs and devs[0]["name"]
    assert ctx.device["name"] in [d["name"] for d in devs]
    assert "binary" in clvox.palettes() and "paper78" in clvox.palettes()
    assert clvox.version() == "0.1.0"


def test_200_meshes_in_one_context_memory_flat(ctx):
    rng = np.random.default_rng(1)

    def one(i):
        s = 0.5 + rng.random()
        vol = ctx.voxelize((V * s + i * 0.01, F), resolution=16 + i % 8)
        assert vol.occupancy.any()
    for i in range(30):  # warm up allocator and caches
        one(i)
    before = rss_kib()
    for i in range(200):
        one(i)
    grown = rss_kib() - before
    assert grown < 8 * 1024, f"RSS grew by {grown} KiB over 200 calls"


def test_error_status(ctx, tmp):
    with pytest.raises(FileNotFoundError):
        ctx.voxelize(str(tmp / "missing.off"))
    bad = tmp / "bad.off"
    bad.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n")
    with pytest.raises(clvox.Error) as e:
        ctx.voxelize(bad)
    assert e.value.status_name == "mesh_format" and "bad.off" in e.value.message
    with pytest.raises(ValueError, match=r"cannot tell the format of '.*x\.vox' from its extension"):
        ctx.voxelize_to_file(DEFAULT, tmp / "x.vox")
    with pytest.raises(clvox.Error) as e:
        clvox.Context(device="no-such-device-xyz")
    assert e.value.status_name == "no_device"
    with pytest.raises(clvox.Error) as e:
        ctx.voxelize(DEFAULT, method="tetra", oversample=2)
    assert e.value.status_name == "invalid_argument"


def test_progress_and_cancel(ctx, tmp):
    seen = []
    ctx.voxelize(DEFAULT, resolution=48, slab_depth=4, progress=seen.append)
    assert seen and seen == sorted(seen) and seen[-1] == 1.0 and 0 < seen[0]
    out = tmp / "c.exr"
    with pytest.raises(clvox.CancelledError) as e:
        ctx.voxelize_to_file(DEFAULT, out, resolution=48, slab_depth=4, progress=lambda f: f < 0.3)
    assert e.value.status_name == "cancelled"
    assert os.listdir(tmp) == []

    def boom(f):
        raise ZeroDivisionError("from the callback")
    with pytest.raises(ZeroDivisionError, match="from the callback"):
        ctx.voxelize_to_file(DEFAULT, out, resolution=48, slab_depth=4, progress=boom)
    assert os.listdir(tmp) == []
    assert ctx.voxelize(DEFAULT, resolution=8).occupancy.any()  # still usable


@pytest.mark.parametrize("to_file", [False, True])
def test_ctrl_c_raises_keyboard_interrupt_and_leaves_no_file(ctx, tmp, to_file):
    assert threading.current_thread() is threading.main_thread()
    timer = threading.Timer(0.6, os.kill, (os.getpid(), signal.SIGINT))
    out = tmp / "long.exr"
    cpu0 = time.process_time()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            # about 15 s (30 s of CPU) on a 2-core CPU device when not interrupted
            if to_file:
                ctx.voxelize_to_file(DEFAULT, out, resolution=512, oversample=16)
            else:
                ctx.voxelize(DEFAULT, resolution=512, oversample=16)
    finally:
        timer.cancel()
    # The run stopped early: CPU time (every thread of this process), not
    # wall time, which a loaded machine stretches.
    assert time.process_time() - cpu0 < 6
    assert os.listdir(tmp) == []
    assert ctx.voxelize(DEFAULT, resolution=8).occupancy.any()


def test_gil_released(ctx):
    """A Python thread keeps running while the library works."""
    ticks = []
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            ticks.append(time.monotonic())
            time.sleep(0.005)
    th = threading.Thread(target=spin)
    th.start()
    t0 = time.monotonic()
    ctx.voxelize(DEFAULT, resolution=256, oversample=8)
    t1 = time.monotonic()
    stop.set()
    th.join()
    # Ticks inside the call: with the GIL held the thread could not run at
    # all there; released, it runs every few ms (the call lasts about a
    # second). Not a share of the call's wall time: a loaded machine
    # delays a sleeping thread's wake-ups, so that share is noise.
    inside = sum(1 for t in ticks if t0 < t < t1)
    assert inside >= 5, (inside, t1 - t0)


def test_context_busy_in_other_thread(ctx):
    got = []
    started = threading.Event()

    def slow(f):
        started.set()
        time.sleep(0.05)
        return True
    th = threading.Thread(target=lambda: got.append(ctx.voxelize(DEFAULT, resolution=64, slab_depth=2,
                                                                 progress=slow)))
    th.start()
    started.wait(10)
    with pytest.raises(RuntimeError, match="one Context per thread"):
        ctx.voxelize(DEFAULT, resolution=8)
    th.join()
    assert got and got[0].occupancy.any()


def test_device_set_same_voxels():
    """Context(device="all") over two PoCL devices (another process: PoCL reads
    POCL_DEVICES once): two devices, the same voxels as one, per-device stats."""
    import subprocess
    import sys
    code = r'''
import sys, numpy as np, clvox
mesh = sys.argv[1]
one = clvox.Context(device="0")
both = clvox.Context(device="all")
pair = clvox.Context(device=[0, 1])
assert len(one.devices) == 1 and len(both.devices) == 2 and len(pair.devices) == 2, (one.devices, both.devices)
assert both.warnings == [], both.warnings
a = one.voxelize(mesh, resolution=48, slab_depth=1)
b = both.voxelize(mesh, resolution=48, slab_depth=1)
c = pair.voxelize(mesh, resolution=48, oversample=2)
d = one.voxelize(mesh, resolution=48, oversample=2)
assert np.array_equal(a.occupancy, b.occupancy) and a.occupancy.any()
assert np.array_equal(c.coverage, d.coverage)
devs = b.stats["devices"]
assert len(devs) == 2 and sum(e["slices"] for e in devs) == a.occupancy.shape[0], devs
assert 0 < b.stats["scheduling_efficiency"] <= 1
print("OK")
'''
    env = dict(os.environ, POCL_DEVICES="basic basic", PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    env.pop("CLVOX_DEVICE", None)
    p = subprocess.run([sys.executable, "-c", code, DEFAULT], capture_output=True, text=True, env=env, timeout=300)
    assert p.returncode == 0 and p.stdout.strip().endswith("OK"), p.stdout + p.stderr
