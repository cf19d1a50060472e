#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Float kernels against double kernels (issue 37), not a test: the same
# clvox run with the kernels built in double and built as for a device
# without fp64 (CLVOX_KERNEL_FLOAT=1), interleaved, on the same device.
#
#   scripts/bench/bench_float.sh [-r N] [--cov-r N] [--repeat R] [--quick]
#
#   -r N        grid resolution (default 256)
#   --cov-r N   the coverage cases' resolution (default 128)
#   --repeat R  runs per case, the best whole-process wall time is shown
#               (default 3)
#   --quick     armadillo and elephant-with-holes only
#   --only TEXT the rows whose case name contains TEXT (e.g. tetra,
#               coverage, "open")
#
# Cases: closed meshes (armadillo 52 k triangles, bunny00 75 k) in the
# default mode (winding: on a closed mesh parity's voxels), --inside parity,
# --method tetra, --mode surface; open meshes of the winding benchmark
# (elephant-with-holes, holes, cylinder, mech-holes-shark, mushroom,
# nefertiti, b9_mesh) in the default mode, on cubic voxels and on voxels
# that are not cubes (the box divided into N x 0.8 N x 0.7 N); coverage (grey levels, the
# default winding test): the closed meshes with 3^3 samples uniform and 2x2
# rays x 3 points stochastic, elephant-with-holes, holes and cylinder with
# 2^3 samples; the planar10 palette with 4x4 samples on armadillo (64^3)
# and elephant-with-holes (48^3). Each row: double and float
# seconds, their ratio, and whether the two EXR files are byte-identical
# (else the filled-voxel counts), and the float run's points decided on the
# host in double (clvox_stats.winding_host_points). Markdown to stdout and to
# build/bench/float.md.
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"
res=256 cov_res=128 repeat=3 quick=0 only=""
while [ $# -gt 0 ]; do
  case "$1" in
    -r) res=${2:?-r needs a number}; shift ;;
    --cov-r) cov_res=${2:?--cov-r needs a number}; shift ;;
    --repeat) repeat=${2:?--repeat needs a number}; shift ;;
    --quick) quick=1 ;;
    --only) only=${2:?--only needs a text}; shift ;;
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
bin=build/release/clvox
[ -x "$bin" ] || make -j2 >/dev/null
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
out=build/bench/float
mkdir -p "$out"
md=build/bench/float.md

best() { # best of $repeat wall times of: env VAR=VALUE... clvox ARGS
  local b="" t
  for _ in $(seq "$repeat"); do
    local s e
    s=$(date +%s.%N)
    env "$@" > /dev/null 2> "$out/err" || { echo "fail"; return; }
    e=$(date +%s.%N)
    t=$(echo "$e - $s" | bc -l)
    if [ -z "$b" ] || [ "$(echo "$t < $b" | bc -l)" = 1 ]; then b=$t; fi
  done
  printf '%.2f' "$b"
}

row() { # NAME MESH ARGS... (ROW_RES=N: that resolution; ROW_DIMS=X,Y,Z: --dims instead)
  local name=$1 mesh=$2 res=${ROW_RES:-$res}; shift 2
  local grid=(-r "$res") label="$res^3"
  if [ -n "${ROW_DIMS:-}" ]; then grid=(--dims "$ROW_DIMS"); label="${ROW_DIMS//,/x}"; fi
  case "$name" in *"$only"*) ;; *) return ;; esac
  [ -f "data/meshes/$mesh.off" ] || { echo "| $name | $mesh | missing | | | |"; return; }
  local a="$out/double.exr" b="$out/float.exr"
  # warm both builds' program caches once
  "$bin" "data/meshes/$mesh.off" -r 8 -q -o "$out/warm.exr" "$@" > /dev/null 2>&1 || true
  CLVOX_KERNEL_FLOAT=1 "$bin" "data/meshes/$mesh.off" -r 8 -q -o "$out/warm.exr" "$@" > /dev/null 2>&1 || true
  local td tf
  td=$(best CLVOX_KERNEL_FLOAT=0 "$bin" "data/meshes/$mesh.off" "${grid[@]}" -q -o "$a" "$@")
  tf=$(best CLVOX_KERNEL_FLOAT=1 "$bin" "data/meshes/$mesh.off" "${grid[@]}" -q -o "$b" "$@")
  local same ratio="-"
  if [ "$td" = fail ] || [ "$tf" = fail ]; then same="run failed: $(head -c 200 "$out/err")"
  elif cmp -s "$a" "$b"; then same="identical"
  else same="differ: $("$bin" info "$a" | grep -i filled | head -1) vs $("$bin" info "$b" | grep -i filled | head -1)"; fi
  [ "$td" != fail ] && [ "$tf" != fail ] && ratio=$(printf '%.2f' "$(echo "$tf / $td" | bc -l)")
  # the float run's points decided on the host (winding runs), one more run
  local host
  host=$(CLVOX_KERNEL_FLOAT=1 "$bin" "data/meshes/$mesh.off" "${grid[@]}" -o "$b" --json "$@" 2>/dev/null |
         grep -o '"host_points":[0-9]*' | cut -d: -f2 || true)
  echo "| $name | $mesh $label | $td | $tf | $ratio | $same | ${host:--} |"
}

{
  echo "Float kernels (CLVOX_KERNEL_FLOAT=1) against double, ${res}^3, best of $repeat, whole process (s), $(nproc) cores, $(date -u +%Y-%m-%d)"
  echo
  echo "| case | mesh | double | float | float/double | bytes | host points |"
  echo "|---|---|---|---|---|---|---|"
  closed="armadillo bunny00"; open="elephant-with-holes holes cylinder mech-holes-shark mushroom nefertiti b9_mesh"
  [ "$quick" = 1 ] && closed=armadillo && open=elephant-with-holes
  for m in $closed; do
    row "default (winding)" "$m"
    row "parity" "$m" --inside parity
    row "tetra" "$m" --method tetra
    row "surface" "$m" --mode surface
  done
  for m in $open; do row "default (winding), open" "$m"; done
  # voxels that are not cubes: the box divided into res x 0.8 res x 0.7 res
  for m in $open; do
    ROW_DIMS="$res,$((res * 4 / 5)),$((res * 7 / 10))" row "default (winding), open, voxels not cubes" "$m"
  done
  for m in $closed; do
    ROW_RES=$cov_res row "coverage 3^3" "$m" --oversample 3
    ROW_RES=$cov_res row "coverage 2x2x3 stochastic" "$m" --oversample 2,3 --stochastic
  done
  cov_open="elephant-with-holes holes cylinder"
  [ "$quick" = 1 ] && cov_open=elephant-with-holes
  for m in $cov_open; do ROW_RES=$cov_res row "coverage 2^3, open" "$m" --oversample 2; done
  ROW_DIMS="$cov_res,$((cov_res * 4 / 5)),$((cov_res * 7 / 10))" row "coverage 2^3, open, voxels not cubes" \
    elephant-with-holes --oversample 2
  ROW_RES=64 row "palette planar10 4x4" armadillo --palette planar10 --samples 4,4
  ROW_RES=48 row "palette planar10 4x4, open" elephant-with-holes --palette planar10 --samples 4,4
} | tee "$md"
