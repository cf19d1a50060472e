#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""IoU of voxel volumes against the exact winding-number oracle, for
scripts/bench/bench_winding.sh (not a test).

    bench_winding_iou.py ORACLE.npy [--json GRID.json] [--trimesh MESH [--samples K] [--seed S]]
                         NAME=VOL.npy ...

Every VOL.npy is a clvox uint8 npy (Z, Y, X) on the oracle's grid; prints one
tab-separated line per NAME: NAME, IoU, voxels only in VOL, voxels only in the
oracle. With --trimesh (needs trimesh, rtree and scipy; skipped with a note
otherwise) also trimesh's `contains` (ray parity) and `voxelized(pitch).fill()`
on K voxel centres drawn at random (default 20000; the grid from GRID.json,
clvox's npy sidecar), as IoU over those centres, with their seconds.
"""
import json
import sys
import time

import numpy as np


def iou(a, b):
    inter = np.count_nonzero(a & b)
    union = np.count_nonzero(a | b)
    return (inter / union if union else 1.0), int(np.count_nonzero(a & ~b)), int(np.count_nonzero(b & ~a))


def main(argv):
    oracle = np.load(argv[0]).astype(bool)
    rest = argv[1:]
    grid_json = mesh = None
    samples, seed = 20000, 1
    vols = []
    while rest:
        a = rest.pop(0)
        if a == "--json":
            grid_json = rest.pop(0)
        elif a == "--trimesh":
            mesh = rest.pop(0)
        elif a == "--samples":
            samples = int(rest.pop(0))
        elif a == "--seed":
            seed = int(rest.pop(0))
        else:
            name, path = a.split("=", 1)
            vols.append((name, path))
    for name, path in vols:
        v = np.load(path).astype(bool)
        if v.shape != oracle.shape:
            print(f"{name}\tshape {v.shape} != oracle {oracle.shape}\t-\t-")
            continue
        j, only_v, only_o = iou(v, oracle)
        print(f"{name}\t{j:.6f}\t{only_v}\t{only_o}")
    if mesh is None:
        return 0
    try:
        import trimesh  # noqa: F401
        import rtree  # noqa: F401
        import scipy  # noqa: F401
    except ImportError as e:
        print(f"trimesh-contains\tskipped ({e.name} missing)\t-\t-")
        print(f"trimesh-fill\tskipped ({e.name} missing)\t-\t-")
        return 0
    with open(grid_json) as f:
        meta = json.load(f)
    g = meta.get("grid", meta)
    origin = np.array(g["origin"], dtype=float)
    h = np.array(g["voxel_size"], dtype=float)
    Z, Y, X = oracle.shape
    rng = np.random.default_rng(seed)
    n = min(samples, oracle.size)
    flat = rng.choice(oracle.size, size=n, replace=False)
    k, rem = np.divmod(flat, X * Y)
    j, i = np.divmod(rem, X)
    pts = origin + (np.stack([i, j, k], axis=1) + 0.5) * h
    want = oracle.reshape(-1)[flat]
    m = trimesh.load(mesh, process=False, force="mesh")
    for name, fn in (("trimesh-contains", lambda: m.contains(pts)),
                     ("trimesh-fill", lambda: m.voxelized(pitch=float(h.min())).fill().is_filled(pts))):
        t0 = time.perf_counter()
        try:
            got = np.asarray(fn(), dtype=bool)
        except Exception as e:  # report, never stop the benchmark
            print(f"{name}\tfailed ({type(e).__name__}: {e})\t-\t-")
            continue
        dt = time.perf_counter() - t0
        jj, only_v, only_o = iou(got, want)
        print(f"{name}\t{jj:.6f}\t{only_v}\t{only_o}\t{dt:.2f}s on {n} sampled centres")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
