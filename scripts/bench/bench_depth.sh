#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Quadtree depth sweep (Thon et al. Table 3: how max depth trades partition
# time against cast time). Not a test. Runs build/release/clvox with
# --depth 1..12 (and 0 = auto) on the given meshes at one grid size and prints
# a markdown table of partition / cast / total seconds (best of R runs).
#
#   scripts/bench/bench_depth.sh [-r N] [--repeat R] [MESH...]
#   default: -r 512, R = 3, data/meshes/armadillo.off data/meshes/armadillo_s3.ply
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
cd "$(dirname "$0")/../.."
n=512 repeat=3 meshes=()
while [ $# -gt 0 ]; do
  case "$1" in
    -r) n=$2; shift ;;
    --repeat) repeat=$2; shift ;;
    -h|--help) sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) meshes+=("$1") ;;
  esac
  shift
done
[ ${#meshes[@]} -gt 0 ] || meshes=(data/meshes/armadillo.off data/meshes/armadillo_s3.ply)
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$PWD/build/pocl-cache}"
mkdir -p "$POCL_CACHE_DIR" build/bench
bin=build/release/clvox
[ -x "$bin" ] || make -s
out=build/bench/depth.exr
echo "| mesh | N | depth | leaves | partition s | cast s | classify s | total s |"
echo "|---|---|---|---|---|---|---|---|"
for m in "${meshes[@]}"; do
  [ -f "$m" ] || { echo "missing $m (scripts/fetch_meshes.sh; scripts/bench/bench.sh makes the subdivided meshes)" >&2; continue; }
  "$bin" "$m" -r "$n" -o "$out" -q || true   # warm the kernel cache
  for d in 0 1 2 3 4 5 6 7 8 9 10 11 12; do
    best=""
    for _ in $(seq "$repeat"); do
      s=$("$bin" "$m" -r "$n" --depth "$d" -o "$out" --compression none)
      t=$(echo "$s" | sed -n 's/.*total \([0-9.]*\) s.*/\1/p')
      if [ -z "$best" ] || awk "BEGIN{exit !($t < $best)}"; then best=$t; line=$s; fi
    done
    part=$(echo "$line" | sed -n 's/.*partition \([0-9.]*\).*/\1/p')
    cast=$(echo "$line" | sed -n 's/.* cast \([0-9.]*\).*/\1/p')
    cls=$(echo "$line" | sed -n 's/.*classify \([0-9.]*\).*/\1/p')
    tris=$(echo "$line" | sed -n 's/^ *\([0-9]*\) triangles.*/\1/p')
    leaves=$(echo "$line" | sed -n 's/.*quadtree depth \([0-9]*\).*, \([0-9]*\) leaves.*/\2/p')
    reached=$(echo "$line" | sed -n 's/.*quadtree depth \([0-9]*\).*/\1/p')
    label=$d; [ "$d" = 0 ] && label="auto ($reached)"
    echo "| $(basename "$m") ($tris tris) | $n | $label | $leaves | $part | $cast | $cls | $best |"
  done
done
rm -f "$out"
