#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# The cracked-soup case of issue 35 (a benchmark, not a test): armadillo
# (data/meshes/armadillo.off, 52 000 triangles) turned into a triangle soup
# -- no shared vertices, each coordinate jittered by up to 1e-6 of the
# bounding box's largest side, seeded (build/release/bench/subdivide
# --soup) -- voxelized by clvox with the default inside test (exact winding
# number) at each resolution; prints per run the whole-process wall time,
# clvox's total, the exact points and the device time of the batches that
# had any (clvox_stats.winding_exact_seconds; per point an upper bound), and
# whether the certified crack weld ran (docs/design.md "Cracks"). --off-r
# also runs the given resolutions with it switched off (CLVOX_CRACK_WELD=0:
# the same voxels the slow way; cmp checks the files are identical).
#
#   scripts/bench/bench_winding_soup.sh [-r "64 128 512"] [--off-r "64 128"] [--jitter REL] [--mesh FILE.off]
#
# Writes a markdown table to stdout and build/bench/winding_soup.md.
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"

res="64 128 512" off_res="" rel=1e-6 mesh=data/meshes/armadillo.off
while [ $# -gt 0 ]; do
  case "$1" in
    -r) res=${2:?-r needs resolutions}; shift ;;
    --off-r) off_res=${2:?--off-r needs resolutions}; shift ;;
    --jitter) rel=${2:?--jitter needs a number}; shift ;;
    --mesh) mesh=${2:?--mesh needs a file}; shift ;;
    -h|--help) sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
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
run() { # N OFF(0/1)
  local n=$1 off=$2 t0 t1 json
  t0=$(date +%s.%N)
  if [ "$off" = 1 ]; then
    json=$(CLVOX_CRACK_WELD=0 "$clvox" "$soup" -r "$n" -o build/bench/winding_soup_off.npy --json)
  else
    json=$("$clvox" "$soup" -r "$n" -o build/bench/winding_soup_on_$n.npy --json)
  fi
  t1=$(date +%s.%N)
  same=""
  if [ "$off" = 1 ]; then
    if cmp -s build/bench/winding_soup_off.npy build/bench/winding_soup_on_$n.npy; then same="identical"; else same="DIFFERENT"; fi
  fi
  python3 - "$json" "$(basename "$mesh")" "$rel" "$n" "$t0" "$t1" "$off" "$same" <<'PY'
import json, sys
j = json.loads(sys.argv[1]); w = j["winding"]
per = w["seconds_per_exact_point"]; cw = w.get("crack_weld")
weld = "off" if sys.argv[7] == "1" else ("%d pairs" % cw["pairs"] if cw else "not used")
print("| %s soup | %s | %s | %s | %.2f | %.2f | %d | %.2f | %s | %d | %s |" % (
    sys.argv[2], sys.argv[3], sys.argv[4], weld, float(sys.argv[6]) - float(sys.argv[5]), j["seconds"]["total"],
    w["exact_points"], w["exact_seconds"], "-" if per is None else "%.1f" % (per * 1e6), j["filled_voxels"], sys.argv[8]))
PY
}
{
  echo "| mesh | jitter | N | crack weld | wall s | clvox total s | exact points | exact batches s | us / exact point (upper bound) | filled | weld off vs on |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|"
  for n in $res; do
    run "$n" 0
    case " $off_res " in *" $n "*) run "$n" 1 ;; esac
  done
} | tee "$out"
rm -f build/bench/winding_soup_on_*.npy build/bench/winding_soup_off.npy
