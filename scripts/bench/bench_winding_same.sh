#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Byte-identity of two builds' winding outputs (not a test; issue 9): runs
# both on every open mesh under data/meshes (or the ones named) with each
# option set and cmp's the files. Base outputs are kept in CACHE and
# reused, so that a second check only runs this build.
#
#   scripts/bench/bench_winding_same.sh --base BIN [--cache DIR] [-r N] [--opts "A|B|..."] [MESH ...]
#
#   --base BIN   the reference clvox
#   --cache DIR  where its outputs are kept (default /tmp/clvox-same-<N>)
#   -r N         grid resolution (default 128)
#   --opts       option sets separated by | (default: none, x/y/z rays,
#                winding-abs, --oversample 2)
# Prints one line per difference and a summary; exit 1 when any differ.
set -eu
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"
n=128 base="" cache="" opts="--axis x|--axis y|--axis z|--inside winding-abs|--oversample 2"
while [ $# -gt 0 ]; do
  case "$1" in
    -r) n=$2; shift 2 ;;
    --base) base=$2; shift 2 ;;
    --cache) cache=$2; shift 2 ;;
    --opts) opts=$2; shift 2 ;;
    -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
    *) break ;;
  esac
done
[ -n "$base" ] || { echo "bench_winding_same.sh: --base BIN needed" >&2; exit 2; }
cache=${cache:-/tmp/clvox-same-$n}
mkdir -p "$cache"
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
mkdir -p "$POCL_CACHE_DIR"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ $# -eq 0 ]; then # the open meshes: those whose preparation closes holes
  for f in data/meshes/*; do
    h=$(build/clvox "$f" -r 16 --no-progress -o "$tmp/p.exr" 2>/dev/null |
      sed -n 's/.* \([0-9]*\) holes closed.*/\1/p') || true
    [ -n "$h" ] && [ "$h" != 0 ] && set -- "$@" "$(basename "$f")"
  done
fi
same=0 diff=0
for m in "$@"; do
  IFS='|'
  for o in $opts; do
    unset IFS
    key=$(echo "${m}_$o" | tr -c 'A-Za-z0-9_.\n-' '_')
    [ -f "$cache/$key.exr" ] || "$base" "data/meshes/$m" -r "$n" $o --no-progress -q -o "$cache/$key.exr"
    build/clvox "data/meshes/$m" -r "$n" $o --no-progress -q -o "$tmp/new.exr"
    if cmp -s "$cache/$key.exr" "$tmp/new.exr"; then same=$((same + 1)); else diff=$((diff + 1)); echo "DIFFERS: $m -r $n $o"; fi
    IFS='|'
  done
  unset IFS
done
echo "$same identical, $diff differ (-r $n, $# meshes)"
[ "$diff" -eq 0 ]
