#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Partition (grid-space transform + quadtree) and whole-process seconds
# against host threads and triangle count (not a test; issue 10). Runs
# `clvox MESH -r N --inside parity` with CLVOX_HOST_THREADS=1..T, the
# thread counts interleaved in each round, and prints per mesh and thread
# count the best and median of the summary's load and partition seconds,
# the wall and the peak RSS (GNU time, KiB).
#
#   scripts/bench/bench_partition_threads.sh [-r N] [--repeat R] [--threads "1 2"] [MESH ...]
#
#   MESH  paths (default: data/meshes/armadillo.off, armadillo_s2.ply,
#         armadillo_s3.ply; the subdivided ones are made by scripts/bench/subdivide.c
#         when missing)
set -eu
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"
n=512 rounds=5 threads="1 2"
while [ $# -gt 0 ]; do
  case "$1" in
    -r) n=$2; shift 2 ;;
    --repeat) rounds=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    *) break ;;
  esac
done
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
export CLVOX_CACHE_DIR="${CLVOX_CACHE_DIR:-$here/build/clvox-cache}"
mkdir -p "$POCL_CACHE_DIR"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ $# -eq 0 ]; then
  for s in 2 3; do
    f=data/meshes/armadillo_s$s.ply
    if [ ! -f "$f" ]; then
      [ -x build/release/bench/subdivide ] || make -s CONFIG=release bench-tools >&2
      build/release/bench/subdivide data/meshes/armadillo.off "$s" "$f" > /dev/null
    fi
  done
  set -- data/meshes/armadillo.off data/meshes/armadillo_s2.ply data/meshes/armadillo_s3.ply
fi
build/clvox "$1" -r 16 --no-progress -q -o "$tmp/w.exr" # the kernel binary cached
for m in "$@"; do
  for r in $(seq "$rounds"); do
    for t in $threads; do
      CLVOX_HOST_THREADS=$t /usr/bin/time -f "%e %M" -o "$tmp/time" build/clvox "$m" -r "$n" --inside parity \
        --no-progress -o "$tmp/v.exr" > "$tmp/out"
      lp=$(sed -n 's/^time *load \([0-9.]*\) .* partition \([0-9.]*\) .*/\1 \2/p' "$tmp/out")
      echo "$t $lp $(cat "$tmp/time")" >> "$tmp/$(basename "$m").rows"
    done
  done
  tris=$(sed -n 's/.* \([0-9]*\) triangles.*/\1/p' "$tmp/out" | head -n 1)
  for t in $threads; do
    awk -v t="$t" -v m="$(basename "$m")" -v tris="$tris" '
      $1 == t { n++; l[n] = $2; p[n] = $3; w[n] = $4; k[n] = $5 }
      function sort(a, n,   i, j, x) { for (i = 2; i <= n; i++) { x = a[i]; for (j = i - 1; j >= 1 && a[j] > x; j--) a[j + 1] = a[j]; a[j + 1] = x } }
      function med(a, n) { return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2 }
      END { sort(l, n); sort(p, n); sort(w, n); sort(k, n)
            printf "| %s | %s | %d | %.3f / %.3f | %.3f / %.3f | %.2f / %.2f | %d-%d |\n", m, tris, t, l[1], med(l, n), p[1], med(p, n), w[1], med(w, n), k[1], k[n] }' \
      "$tmp/$(basename "$m").rows"
  done
done
