#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Python binding overhead, measured (python/README.md "Performance").

    make && scripts/bench/bench_python.py [--mesh data/meshes/armadillo.off] [--reps 5]

Needs the clvox package importable (pip install ./python, or PYTHONPATH=build/release/python
after `make test`). In one run, per resolution (128^3 and 512^3 along the longest axis):
  cli      wall time of `clvox MESH -r N -o OUT.exr -q` (a process: OpenCL set-up, kernel
           build from the PoCL cache, mesh load, voxelize, EXR write)
  lib      the library's own time for the call (clvox_stats.seconds total), Python side
  py       wall time of ctx.voxelize(mesh, resolution=N) with a preloaded clvox.Mesh
           (numpy arrays out), and of ctx.voxelize_to_file (the CLI's work minus set-up)
  overhead py - lib: what the binding adds (argument conversion, callbacks, wrapping)
Then 200 small meshes (numpy arrays, 16^3..23^3) in one Context: time per mesh and the RSS
before and after. Medians of --reps runs; the machine is shared, so expect noise.
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import clvox

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def rss_mib():
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def med(xs):
    return statistics.median(xs)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--mesh", default=os.path.join(REPO, "data", "meshes", "armadillo.off"))
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--cli", default=os.path.join(REPO, "build", "release", "clvox"))
    ap.add_argument("--resolutions", default="128,512")
    a = ap.parse_args()
    os.environ.setdefault("POCL_CACHE_DIR", os.path.join(REPO, "build", "pocl-cache"))
    tmp = tempfile.mkdtemp(prefix="clvox-bench-py-")
    t0 = time.perf_counter()
    ctx = clvox.Context()
    t_ctx = time.perf_counter() - t0
    print(f"clvox {clvox.version()} on {ctx.device['name']}; Context() {t_ctx:.3f} s; mesh {a.mesh}")
    t0 = time.perf_counter()
    mesh = ctx.mesh(a.mesh)
    t_load = time.perf_counter() - t0
    print(f"mesh load {t_load * 1e3:.1f} ms ({mesh.report['triangles']} triangles)")
    print(f"{'N':>5} {'cli wall':>9} {'py file':>9} {'lib file':>9} {'py mem':>9} {'lib mem':>9} "
          f"{'overhead mem':>13} {'py path':>9}")
    for n in (int(x) for x in a.resolutions.split(",")):
        out = os.path.join(tmp, "v.exr")
        cli, pyf, libf, pym, libm, pyp = [], [], [], [], [], []
        ctx.voxelize(mesh, resolution=n)  # warm up
        for _ in range(a.reps):
            t0 = time.perf_counter()
            subprocess.run([a.cli, a.mesh, "-r", str(n), "-o", out, "-q", "--no-progress"], check=True,
                           stdout=subprocess.DEVNULL)
            cli.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            st = ctx.voxelize_to_file(mesh, out, resolution=n)
            pyf.append(time.perf_counter() - t0)
            libf.append(st["seconds"]["total"])
            t0 = time.perf_counter()
            v = ctx.voxelize(mesh, resolution=n)
            pym.append(time.perf_counter() - t0)
            libm.append(v.stats["seconds"]["total"])
            del v
            t0 = time.perf_counter()
            v = ctx.voxelize(a.mesh, resolution=n)
            pyp.append(time.perf_counter() - t0)
            del v
        over = [p - q for p, q in zip(pym, libm)]
        print(f"{n:>5} {med(cli):>8.3f}s {med(pyf):>8.3f}s {med(libf):>8.3f}s {med(pym):>8.3f}s "
              f"{med(libm):>8.3f}s {med(over) * 1e3:>7.2f} ms {100 * med(over) / med(libm):>4.1f}% "
              f"{med(pyp):>8.3f}s")
    # 200 small meshes from numpy arrays in one context
    sys.path.insert(0, os.path.join(REPO, "python", "tests"))
    from test_arrays import F, V  # a 512-triangle sphere
    rng = np.random.default_rng(0)
    for i in range(20):
        ctx.voxelize((V, F), resolution=16)
    r0 = rss_mib()
    times, lib = [], []
    for i in range(200):
        t0 = time.perf_counter()
        v = ctx.voxelize((V * (0.5 + rng.random()), F), resolution=16 + i % 8)
        times.append(time.perf_counter() - t0)
        lib.append(v.stats["seconds"]["total"])
    r1 = rss_mib()
    print(f"200 meshes ({len(F)} triangles, 16^3..23^3, arrays in, one Context): "
          f"median {med(times) * 1e3:.2f} ms per mesh (library {med(lib) * 1e3:.2f} ms), "
          f"total {sum(times):.2f} s; RSS {r0:.1f} -> {r1:.1f} MiB")
    for f in os.listdir(tmp):
        os.unlink(os.path.join(tmp, f))
    os.rmdir(tmp)


if __name__ == "__main__":
    main()
