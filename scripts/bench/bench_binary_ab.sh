#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# The binary path of two clvox builds, interleaved (a change must not make
# it slower): armadillo at 512^3 in the default, parity, surface and tetra
# modes, the open meshes elephant-with-holes, holes and cylinder at 256^3 and
# b9_mesh at 128^3 (the default winding test). Best of --repeat whole-process
# wall times each, and whether the two files are byte-identical.
#
#   scripts/bench/bench_binary_ab.sh --base OTHER_CLVOX [--repeat R]
#
# Markdown to stdout and build/bench/binary_ab.md.
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"
base="" repeat=5
while [ $# -gt 0 ]; do
  case "$1" in
    --base) base=${2:?--base needs a clvox binary}; shift ;;
    --repeat) repeat=${2:?--repeat needs a number}; shift ;;
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
[ -x "$base" ] || { echo "bench_binary_ab.sh: --base OTHER_CLVOX is required" >&2; exit 2; }
new=${CLVOX_BENCH_BIN:-build/release/clvox}
[ -x "$new" ] || make -j2 >/dev/null
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}" CLVOX_CACHE_DIR="${CLVOX_CACHE_DIR:-$here/build/clvox-cache}"
out=build/bench/binary_ab; mkdir -p "$out"
wall() { local s e; s=$(date +%s.%N); "$@" -q > /dev/null 2>&1; e=$(date +%s.%N); echo "$e - $s" | bc -l; }
row() { # NAME MESH N ARGS...
  local name=$1 mesh=data/meshes/$2.off n=$3; shift 3
  [ -f "$mesh" ] || { echo "| $name | $mesh missing | | | |"; return; }
  "$base" "$mesh" -r "$n" -o "$out/b.exr" -q "$@"; "$new" "$mesh" -r "$n" -o "$out/n.exr" -q "$@"
  local same=identical bb=99 bn=99 x
  cmp -s "$out/b.exr" "$out/n.exr" || same=DIFFERENT
  for _ in $(seq "$repeat"); do
    x=$(wall "$base" "$mesh" -r "$n" -o "$out/b.exr" "$@"); bb=$(echo "if ($x < $bb) $x else $bb" | bc -l)
    x=$(wall "$new" "$mesh" -r "$n" -o "$out/n.exr" "$@"); bn=$(echo "if ($x < $bn) $x else $bn" | bc -l)
  done
  printf '| %s | %s %s^3 | %.3f | %.3f | %s |\n' "$name" "$(basename "$mesh" .off)" "$n" "$bb" "$bn" "$same"
}
{
  echo "| mode | mesh | base (s) | this build (s) | output |"
  echo "|---|---|---|---|---|"
  row default armadillo 512
  row parity armadillo 512 --inside parity
  row surface armadillo 512 --mode surface
  row tetra armadillo 512 --method tetra
  row default elephant-with-holes 256
  row default holes 256
  row default cylinder 256
  row default b9_mesh 128
} | tee build/bench/binary_ab.md
