#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Cancellation latency of the clvox CLI: the wall time from SIGINT to the
process's exit, for long runs of the ray and tetra methods. The test suite
checks that a cancel stops the work (tests/test_ray.c, in CPU time, which
load does not stretch); how fast that is in wall time is measured here.

    scripts/bench/bench_cancel.py [--bin build/release/clvox] [--reps 5] [--after 1.0]

Prints one line per case: the median and max latency over the repetitions,
and the exit codes seen (130 expected)."""
import argparse, os, signal, statistics, subprocess, sys, tempfile, time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CASES = [
    ("ray, 512^3 oversample 16", ["-r", "512", "--oversample", "16"]),
    ("tetra, 2048^3", ["-r", "2048", "--method", "tetra"]),
    ("winding, 1024^3 oversample 4", ["-r", "1024", "--oversample", "4"]),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", default=os.path.join(ROOT, "build/release/clvox"))
    ap.add_argument("--mesh", default=os.path.join(ROOT, "tests/data/default.obj"))
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--after", type=float, default=0.5, help="seconds from start to SIGINT")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        for name, args in CASES:
            lat, codes = [], set()
            for _ in range(a.reps):
                p = subprocess.Popen([a.bin, a.mesh, "-o", os.path.join(d, "c.exr"), "-q"] + args,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                time.sleep(a.after)
                if p.poll() is not None:
                    print(f"{name}: finished before the signal; use a longer run", file=sys.stderr)
                    break
                t0 = time.monotonic()
                p.send_signal(signal.SIGINT)
                codes.add(p.wait())
                lat.append(time.monotonic() - t0)
            if lat:
                print(f"{name}: SIGINT to exit median {statistics.median(lat):.3f} s, max {max(lat):.3f} s "
                      f"({len(lat)} runs, exit codes {sorted(codes)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
