#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""trimesh's surface voxelization next to clvox's, for scripts/bench/bench_surface.sh.

    bench_surface_trimesh.py MESH N CLVOX VOLUME_RAW TMPDIR [REPEAT]

Times trimesh.Trimesh.voxelized(pitch) (voxelize_subdivide: subdivide until
every edge is shorter than pitch/2, at most 10 rounds, and mark the voxels
holding the vertices) and its .fill() (scipy binary_fill_holes) with pitch =
longest bounding-box side / N, the best of REPEAT runs (default 1). Then runs
clvox --mode surface and --mode conservative on the same grid (voxel centres
at integer multiples of pitch, as trimesh puts them; one voxel of margin) and
compares voxel by voxel. Prints one JSON object.
"""
import json
import subprocess
import sys
import time

import numpy as np
import trimesh


def main():
    mesh_path, n, clvox, volume_raw, tmp = sys.argv[1:6]
    repeat = int(sys.argv[6]) if len(sys.argv) > 6 else 1
    n = int(n)
    t0 = time.perf_counter()
    mesh = trimesh.load(mesh_path, force="mesh", process=False)
    load = time.perf_counter() - t0
    bmin, bmax = mesh.bounds
    pitch = float((bmax - bmin).max()) / n

    best_surf = best_fill = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        vox = mesh.voxelized(pitch)
        t1 = time.perf_counter()
        filled = vox.copy().fill()
        t2 = time.perf_counter()
        best_surf = min(best_surf, t1 - t0)
        best_fill = min(best_fill, t2 - t1)

    # trimesh voxel (a, b, c) has its centre at (a, b, c) * pitch
    lo = np.floor(bmin / pitch).astype(int) - 1
    hi = np.ceil(bmax / pitch).astype(int) + 1
    dims = hi - lo + 1
    box = [*((lo - 0.5) * pitch), *((hi + 0.5) * pitch)]

    def trimesh_set(grid):
        idx = np.round(grid.points / pitch).astype(int) - lo
        keep = np.all((idx >= 0) & (idx < dims), axis=1)
        out = np.zeros(dims[::-1], dtype=bool)  # z, y, x
        out[idx[keep, 2], idx[keep, 1], idx[keep, 0]] = True
        return out, int((~keep).sum())

    def clvox_set(mode):
        exr, raw = f"{tmp}/tm_{mode}.exr", f"{tmp}/tm_{mode}.raw"
        subprocess.run([clvox, mesh_path, "--box", ",".join(f"{x:.17g}" for x in box),
                        "--dims", ",".join(str(int(d)) for d in dims), "--mode", mode,
                        "-o", exr, "-q"], check=True)
        subprocess.run([volume_raw, exr, raw], check=True, stdout=subprocess.DEVNULL)
        return np.fromfile(raw, dtype=np.uint8).reshape(dims[::-1]).astype(bool)

    tm_surf, out_s = trimesh_set(vox)
    tm_fill, out_f = trimesh_set(filled)
    cl_surf = clvox_set("surface")
    cl_cons = clvox_set("conservative")
    print(json.dumps({
        "mesh": mesh_path, "n": n, "pitch": pitch, "dims": [int(d) for d in dims], "load_s": load,
        "trimesh_surface_s": best_surf, "trimesh_fill_s": best_fill,
        "trimesh_surface": int(tm_surf.sum()), "trimesh_filled": int(tm_fill.sum()),
        "clvox_surface": int(cl_surf.sum()), "clvox_conservative": int(cl_cons.sum()),
        "trimesh_surface_not_clvox": int((tm_surf & ~cl_surf).sum()),
        "clvox_surface_not_trimesh": int((cl_surf & ~tm_surf).sum()),
        "trimesh_filled_not_clvox_conservative": int((tm_fill & ~cl_cons).sum()),
        "clvox_conservative_not_trimesh_filled": int((cl_cons & ~tm_fill).sum()),
        "trimesh_outside_grid": out_s + out_f,
    }))


if __name__ == "__main__":
    main()
