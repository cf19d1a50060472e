#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# The cracked-soup case of issue 35, as a baseline (not a test): armadillo
# (data/meshes/armadillo.off, 52 000 triangles) turned into a triangle soup
# -- no shared vertices, each coordinate jittered by up to 1e-6 of the
# bounding box's largest side, seeded (build/release/bench/subdivide
# --soup) -- voxelized by clvox with the default inside test (exact winding
# number) at each resolution; prints per run the whole-process wall time,
# clvox's total, the exact points and the device time of the batches that
# had any (clvox_stats.winding_exact_seconds; per point an upper bound).
#
#   scripts/bench/bench_winding_soup.sh [-r "64 128"] [--jitter REL] [--mesh FILE.off]
#
# Writes a markdown table to stdout and build/bench/winding_soup.md.
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"

res="64 128" rel=1e-6 mesh=data/meshes/armadillo.off
while [ $# -gt 0 ]; do
  case "$1" in
    -r) res=${2:?-r needs resolutions}; shift ;;
    --jitter) rel=${2:?--jitter needs a number}; shift ;;
    --mesh) mesh=${2:?--mesh needs a file}; shift ;;
    -h|--help) sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench_winding_soup.sh: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done
[ -r "$mesh" ] || { echo "bench_winding_soup.sh: $mesh missing (run scripts/fetch_meshes.sh)" >&2; exit 1; }
make -s all bench-tools >/dev/null
clvox=${CLVOX_BENCH_BIN:-build/release/clvox}
mkdir -p build/bench
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$PWD/build/pocl-cache} CLVOX_CACHE_DIR=${CLVOX_CACHE_DIR:-$PWD/build/clvox-cache}
soup=build/bench/$(basename "$mesh" .off)_soup_$rel.ply
build/release/bench/subdivide "$mesh" 0 "$soup" --soup "$rel" 1 >/dev/null
out=build/bench/winding_soup.md
{
  echo "| mesh | jitter | N | wall s | clvox total s | exact points | exact batches s | us / exact point (upper bound) | filled |"
  echo "|---|---|---|---|---|---|---|---|---|"
  for n in $res; do
    t0=$(date +%s.%N)
    json=$("$clvox" "$soup" -r "$n" -o build/bench/winding_soup.exr --json)
    t1=$(date +%s.%N)
    python3 - "$json" "$(basename "$mesh")" "$rel" "$n" "$t0" "$t1" <<'PY'
import json, sys
j = json.loads(sys.argv[1]); w = j["winding"]
per = w["seconds_per_exact_point"]
print("| %s soup | %s | %s | %.2f | %.2f | %d | %.2f | %s | %d |" % (
    sys.argv[2], sys.argv[3], sys.argv[4], float(sys.argv[6]) - float(sys.argv[5]), j["seconds"]["total"],
    w["exact_points"], w["exact_seconds"], "-" if per is None else "%.1f" % (per * 1e6), j["filled_voxels"]))
PY
  done
} | tee "$out"
rm -f build/bench/winding_soup.exr
