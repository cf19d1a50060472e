#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""clvox's exact winding-number voxelization vs libigl's fast winding number
(issue 9; a benchmark, not a test).

For each mesh and grid: the whole `clvox MESH -r N -o OUT.npy` process
(default inside rule: exact generalized winding number w > 1/2; median of R
runs), then libigl's `igl.fast_winding_number(V, F, Q)` (Barnes-Hut, approximate,
Jacobson/Barill et al. 2018) on the same voxel centres in this process (mesh read
by `igl.read_triangle_mesh`; the time is load + evaluation, not Python start-up),
thresholded at 1/2. Reported: wall and CPU seconds of both (libigl uses all
cores, as clvox does), their ratio, and the number of voxels where libigl's
classification differs from clvox's exact one.

With --exact M, `igl.winding_number` (libigl's exact, hierarchical) is also run
on the grids of at most M^3 voxels, and both are compared with it: clvox must
differ in 0 voxels where the mesh is consistently oriented (clvox repairs
orientation, libigl takes the file's; the meshes below are oriented).

    build/venv-igl/bin/python scripts/bench/bench_winding_igl.py [-r 128,256] [--repeat R]
        [--exact M] [MESH ...]

libigl comes from PyPI (`python3 -m venv --system-site-packages build/venv-igl &&
build/venv-igl/bin/pip install libigl==2.6.3`); it is not part of the test
setup. Writes a markdown table to stdout.
"""
import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time

import numpy as np

try:
    import igl
except ImportError:
    sys.exit("bench_winding_igl.py: libigl is not installed (see --help)")

HERE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEFAULT_MESHES = ["elephant-with-holes.off", "mech-holes-shark.off", "mushroom.off", "holes.off",
                  "cylinder.off", "nefertiti.off", "armadillo.off", "bunny00.off"]


def child_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_clvox(clvox, mesh, res, out):
    t0, c0 = time.perf_counter(), child_cpu()
    p = subprocess.run([clvox, mesh, "-r", str(res), "-o", out, "--json"], capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, child_cpu() - c0
    if p.returncode != 0:
        raise RuntimeError(f"clvox failed on {mesh}: {p.stderr.strip()}")
    return wall, cpu, json.loads(p.stdout.strip().splitlines()[-1])


def centres(meta):
    """Voxel centres in array order [z, y, x] (the .npy sidecar's convention)."""
    nx, ny, nz = meta["dims"]
    o, v = meta["origin"], meta["voxel_size"]
    z, y, x = np.meshgrid(o[2] + (np.arange(nz) + 0.5) * v[2], o[1] + (np.arange(ny) + 0.5) * v[1],
                          o[0] + (np.arange(nx) + 0.5) * v[0], indexing="ij")
    return np.column_stack([x.ravel(), y.ravel(), z.ravel()])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-r", default="128,256", help="grid resolutions, comma-separated")
    ap.add_argument("--repeat", type=int, default=3, help="clvox runs per case (median)")
    ap.add_argument("--exact", type=int, default=0, help="also run igl.winding_number up to this resolution")
    ap.add_argument("meshes", nargs="*")
    a = ap.parse_args()
    clvox = os.environ.get("CLVOX_BENCH_BIN", os.path.join(HERE, "build/release/clvox"))
    os.environ.setdefault("POCL_CACHE_DIR", os.path.join(HERE, "build/pocl-cache"))
    tmp = os.path.join(HERE, "build/bench/igl")
    os.makedirs(tmp, exist_ok=True)
    meshes = a.meshes or [os.path.join(HERE, "data/meshes", m) for m in DEFAULT_MESHES]
    print(f"libigl {getattr(igl, '__version__', '2.6')}, numpy {np.__version__}, {os.cpu_count()} cores; "
          f"clvox {clvox} (median of {a.repeat})\n")
    print("| mesh | triangles | grid | clvox wall s | clvox CPU s | exact pts | igl fast wall s | igl fast CPU s "
          "| wall ratio | CPU ratio | igl fast ≠ clvox | igl exact ≠ clvox | igl exact ≠ igl fast |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for mesh in meshes:
        for res in [int(r) for r in a.r.split(",")]:
            out = os.path.join(tmp, "w.npy")
            runs = [run_clvox(clvox, mesh, res, out) for _ in range(a.repeat)]
            cw = statistics.median(r[0] for r in runs)
            cc = statistics.median(r[1] for r in runs)
            rep = runs[-1][2]
            with open(os.path.join(tmp, "w.json")) as f:
                meta = json.load(f)
            vox = np.load(out).astype(bool).ravel()
            t0, c0 = time.perf_counter(), time.process_time()
            V, F = igl.read_triangle_mesh(mesh)
            Q = centres(meta)
            w = igl.fast_winding_number(V, F, Q)
            iw, ic = time.perf_counter() - t0, time.process_time() - c0
            fast = w > 0.5
            exact_cols = "-", "-"
            if a.exact and res <= a.exact:
                we = igl.winding_number(V, F, Q) > 0.5
                exact_cols = str(int(np.count_nonzero(we != vox))), str(int(np.count_nonzero(we != fast)))
            pts = rep.get("winding", {}).get("exact_points", "-")
            print(f"| {os.path.basename(mesh)} | {len(F)} | {res}³ | {cw:.2f} | {cc:.2f} | {pts} | {iw:.2f} | {ic:.2f} "
                  f"| {iw / cw:.1f} | {ic / cc:.1f} | {int(np.count_nonzero(fast != vox))} | {exact_cols[0]} "
                  f"| {exact_cols[1]} |", flush=True)


if __name__ == "__main__":
    main()
