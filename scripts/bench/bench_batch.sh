#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Batch throughput: COUNT small meshes voxelized by one `clvox batch` process
# vs one `clvox` process per mesh, at each resolution in RES.
#   scripts/bench/bench_batch.sh [COUNT [PER_PROCESS_COUNT]]   (defaults 1000 1000)
# The meshes are the CGAL meshes in data/meshes with 100 to 20000 triangles
# (scripts/fetch_meshes.sh), repeated in a manifest up to COUNT lines. The
# per-process side runs the first PER_PROCESS_COUNT of them (a smaller count
# shortens the run on a slow machine; meshes per second is per mesh either
# way; 0 skips that side). Prints meshes per second of both and the ratio.
# RES="64 128" by default; MESH_DIR=data/meshes; BIN=build/release/clvox;
# OPTS: more options for every run (e.g. "--inside parity"); MIN_TRIS,
# MAX_TRIS: the meshes' triangle range (default 100, 20000).
# BASE=OTHER_CLVOX: also batch with that binary, ROUNDS times each (default
# 5), interleaved with BIN, and print the medians and their ratio (an A/B of
# the batch path).
set -eu
here=$(cd "$(dirname "$0")/../.." && pwd)
BIN=${BIN:-$here/build/release/clvox}
COUNT=${1:-1000}
PER=${2:-$COUNT}
RES=${RES:-"64 128"}
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
mkdir -p "$POCL_CACHE_DIR"
work=$(mktemp -d "${TMPDIR:-/tmp}/clvox-bench-batch.XXXXXX")
trap 'rm -rf "$work"' EXIT
meshes=$work/meshes.txt
MESH_DIR=${MESH_DIR:-$here/data/meshes}
for f in "$MESH_DIR"/*.off; do
  t=$(awk 'NR==1 && $1 != "OFF" { exit } NR==1 { next } /^[ \t]*(#|$)/ { next } { print $2; exit }' "$f" 2>/dev/null || true)
  case $t in ''|*[!0-9]*) continue;; esac
  [ "$t" -ge "${MIN_TRIS:-100}" ] && [ "$t" -le "${MAX_TRIS:-20000}" ] || continue
  "$BIN" "$f" -r 8 -q -o "$work/probe.exr" 2>/dev/null || continue   # only meshes clvox takes
  echo "$f" >> "$meshes"
done
[ -s "$meshes" ] || { echo "bench_batch: no meshes in data/meshes (run scripts/fetch_meshes.sh)" >&2; exit 1; }
distinct=$(wc -l < "$meshes")
awk -v n="$COUNT" '{ m[NR] = $0 } END { for (i = 0; i < n; i++) print m[i % NR + 1] }' "$meshes" > "$work/manifest.txt"
now() { date +%s.%N; }
echo "meshes: $COUNT from $distinct distinct meshes of $MESH_DIR (${MIN_TRIS:-100}-${MAX_TRIS:-20000} triangles)${OPTS:+, options $OPTS}; per-process side: $PER; $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
"$BIN" "$(head -n 1 "$meshes")" -r 8 -q -o "$work/warm.exr"   # PoCL kernel cache warm for both sides
OPTS=${OPTS:-}
batch_s() { # BINARY RES: seconds of one batch over the manifest
  rm -rf "$work/out"; mkdir "$work/out"
  a=$(now)
  # shellcheck disable=SC2086
  "$1" batch --manifest "$work/manifest.txt" -r "$2" -o "$work/out/{n}.exr" -q $OPTS 2>> "$work/stderr.txt"
  b=$(now)
  awk -v a="$a" -v b="$b" 'BEGIN { printf "%.3f\n", b - a }'
}
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
if [ -n "${BASE:-}" ]; then
  "$BASE" "$(head -n 1 "$meshes")" -r 8 -q -o "$work/warm.exr"
  for r in $RES; do
    : > "$work/this.txt"; : > "$work/base.txt"
    i=0
    while [ "$i" -lt "${ROUNDS:-5}" ]; do
      batch_s "$BASE" "$r" >> "$work/base.txt"
      batch_s "$BIN" "$r" >> "$work/this.txt"
      i=$((i + 1))
    done
    tb=$(median < "$work/base.txt"); tt=$(median < "$work/this.txt")
    awk -v r="$r" -v n="$COUNT" -v tb="$tb" -v tt="$tt" -v lb="$(tr '\n' ' ' < "$work/base.txt")" \
        -v lt="$(tr '\n' ' ' < "$work/this.txt")" 'BEGIN {
      printf "%4d^3  batch of %d, median of %s: base %.2f s = %.1f meshes/s, this %.2f s = %.1f meshes/s, %.2fx  (base: %s; this: %s)\n",
             r, n, "'"${ROUNDS:-5}"'", tb, n / tb, tt, n / tt, tb / tt, lb, lt }'
  done
  [ "$PER" -gt 0 ] || exit 0
fi
for r in $RES; do
  rm -rf "$work/out"; mkdir "$work/out"
  t0=$(now)
  # shellcheck disable=SC2086
  "$BIN" batch --manifest "$work/manifest.txt" -r "$r" -o "$work/out/{n}.exr" -q $OPTS
  t1=$(now)
  [ "$PER" -gt 0 ] || { awk -v r="$r" -v n="$COUNT" -v a="$t0" -v b="$t1" 'BEGIN {
    printf "%4d^3  batch: %d meshes in %.2f s = %.1f meshes/s\n", r, n, b - a, n / (b - a) }'; continue; }
  rm -rf "$work/out"; mkdir "$work/out"
  i=0
  head -n "$PER" "$work/manifest.txt" | while IFS= read -r m; do
    # shellcheck disable=SC2086
    "$BIN" "$m" -r "$r" -q -o "$work/out/$i.exr" $OPTS; i=$((i + 1))
  done
  t2=$(now)
  awk -v r="$r" -v n="$COUNT" -v p="$PER" -v a="$t0" -v b="$t1" -v c="$t2" 'BEGIN {
    bt = b - a; pt = c - b; bm = n / bt; pm = p / pt;
    printf "%4d^3  batch: %d meshes in %.2f s = %.1f meshes/s   per process: %d in %.2f s = %.2f meshes/s   ratio %.1fx\n",
           r, n, bt, bm, p, pt, pm, bm / pm }'
done
