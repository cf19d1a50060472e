#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Cost of the winding inside test on open meshes, two builds interleaved
# (not a test; issue 9): whole-process wall and CPU seconds (user + system,
# the steadier figure on a shared machine), best of R rounds, and how many
# centres needed exact cap solid angles.
#
#   scripts/bench/bench_winding_cost.sh [-r N] [--repeat R] [--base BIN] [MESH ...]
#
#   -r N        grid resolution (default 128)
#   --repeat R  rounds (default 2)
#   --base BIN  the "before" clvox (default: none, only this build)
#   MESH        names under data/meshes (default: the open real meshes of
#               docs/benchmarks.md "Winding numbers")
# Prints a Markdown table row per mesh.
set -eu
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"
n=128 rounds=2 base=""
while [ $# -gt 0 ]; do
  case "$1" in
    -r) n=$2; shift 2 ;;
    --repeat) rounds=$2; shift 2 ;;
    --base) base=$2; shift 2 ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) break ;;
  esac
done
[ $# -gt 0 ] || set -- mech-holes-shark.off elephant-with-holes.off holes.off cylinder.off nefertiti.off \
  lion.off mask_cone.off mushroom.off head.off pig.off
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
mkdir -p "$POCL_CACHE_DIR"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# one BIN MESH -> "wall cpu exact"
one() {
  /usr/bin/time -f "%e %U %S" -o "$tmp/time" "$1" "data/meshes/$2" -r "$n" --no-progress -o "$tmp/v.exr" > "$tmp/out"
  ex=$(sed -n 's/.*caps, \([0-9]*\) points exact.*/\1/p' "$tmp/out")
  awk -v ex="${ex:-0}" '{print $1, $2 + $3, ex}' "$tmp/time"
}
best() { awk -v a="$1" -v b="$2" 'BEGIN { print (a == "" || b + 0 < a + 0) ? b : a }'; }
echo "| mesh | N | wall base | wall | CPU s base | CPU s | exact base | exact | load |"
echo "|---|---|---|---|---|---|---|---|---|"
for m in "$@"; do
  w0="" c0="" e0="-" w1="" c1="" e1="-"
  i=0
  while [ $i -lt "$rounds" ]; do
    if [ -n "$base" ]; then
      set -- $(one "$base" "$m"); w0=$(best "$w0" "$1"); c0=$(best "$c0" "$2"); e0=$3
    fi
    set -- $(one build/clvox "$m"); w1=$(best "$w1" "$1"); c1=$(best "$c1" "$2"); e1=$3
    i=$((i + 1))
  done
  echo "| ${m%.*} | $n | ${w0:--} | $w1 | ${c0:--} | $c1 | $e0 | $e1 | $(cut -d' ' -f1 /proc/loadavg) |"
done
