#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Every kernel path under Oclgrind (Debian's oclgrind, an OpenCL 1.2 device
# simulator): the clvox CLI run under `oclgrind --data-races --check-api`
# and again under `oclgrind --max-wgsize 16`, on small grids, every mode,
# closed and open meshes, several ray axes. A case passes when the run
# exits 0, Oclgrind logged nothing (no out-of-bounds access, data race, API
# error or invalid barrier), clvox's stderr equals the PoCL run's, and the
# output file equals the PoCL run's byte for byte. Then the negative
# checks: the kernels built with -DCLVOX_TEST_BROKEN_KERNEL=1 (a write past
# a buffer) and =2 (a data race), through oclgrind --build-options, must make
# a case fail. The Makefile copies this script to
# build/$CONFIG/tests/test_oclgrind; tests/run_tests.sh runs it like the C
# test programs. Ends with one "N passed, N failed" line. docs/testing.md.
# The same cases also run on PoCL with CLVOX_LOCAL_SIZE=1 (work-groups of
# one work-item) and must give the same bytes. The float build of the
# kernels (CLVOX_KERNEL_FLOAT=1) runs under Oclgrind too, in the modes it
# decides exactly, and must give the double kernels' bytes.
set -u
here=$(cd "$(dirname "$0")" && pwd)          # build/CONFIG/tests
build=$(dirname "$here")
repo=$(cd "$build/../.." && pwd)
bin=${CLVOX_BIN:-$build/clvox}
case "${CONFIG:-release}" in
  release|debug) ;;
  *) # oclgrind preloads its OpenCL runtime: the sanitizers' runtimes must come first
     echo "SKIP oclgrind tests: CONFIG=${CONFIG} (oclgrind's LD_PRELOAD and the sanitizer runtime exclude each other)"
     echo "0 passed, 0 failed"; exit 0 ;;
esac
if ! command -v oclgrind >/dev/null 2>&1; then
  echo "FAIL: oclgrind not found (Debian package oclgrind; scripts/setup.sh installs it)"
  echo "0 passed, 1 failed"; exit 1
fi
meshes="$repo/data/meshes"
for m in cow cube-ouvert corner_with_hole elephant-with-holes cross; do
  if [ ! -f "$meshes/$m.off" ]; then
    if [ -n "${CLVOX_QUICK:-}" ]; then echo "quick run: real meshes absent, oclgrind cases skipped"; echo "0 passed, 0 failed"; exit 0; fi
    echo "FAIL: $meshes/$m.off missing (scripts/fetch_meshes.sh)"; echo "0 passed, 1 failed"; exit 1
  fi
done
tmp="${CLVOX_TEST_TMP:-$repo/build/test-tmp}/oclgrind"
rm -rf "$tmp"; mkdir -p "$tmp" || exit 1
# Oclgrind's program binaries in a cache of their own (the cache key names
# the device too, so PoCL's are never taken: this keeps the check simple).
export CLVOX_CACHE_DIR="$tmp/cache"
passed=0; failed=0; n=0
pass() { passed=$((passed + 1)); }
fail() { failed=$((failed + 1)); echo "FAIL: $*"; }

# check_case LABEL OCLGRIND-OPTIONS -- CLVOX-ARGS: 0 when it passes, else
# prints why (prefixed with LABEL) and returns 1. The PoCL reference of the
# same arguments is run once per case and kept.
check_case() {
  label=$1; opts=$2; shift 2
  n=$((n + 1)); d="$tmp/c$n"; mkdir -p "$d"
  key=$(printf '%s\n' "$*" | cksum | cut -d' ' -f1)
  ref="$tmp/ref-$key.exr"
  if [ ! -f "$ref" ]; then
    "$bin" "$@" -q -o "$ref" 2> "$tmp/ref-$key.err"
    rc=$?
    if [ $rc -ne 0 ]; then echo "$label: the PoCL run failed (exit $rc): $(head -n 3 "$tmp/ref-$key.err")"; return 1; fi
  fi
  case "$opts" in
    pocl-local=*) # PoCL with work-groups of at most N work-items (CLVOX_LOCAL_SIZE)
      CLVOX_LOCAL_SIZE=${opts#pocl-local=} "$bin" "$@" -q -o "$d/out.exr" > "$d/stdout" 2> "$d/stderr"
      rc=$?; : > "$d/oclgrind.log" ;;
    float:*) # the kernels built as for a device without fp64, under Oclgrind
      # shellcheck disable=SC2086 # opts: several words
      CLVOX_KERNEL_FLOAT=1 oclgrind ${opts#float:} --log "$d/oclgrind.log" "$bin" "$@" -q -o "$d/out.exr" \
        > "$d/stdout" 2> "$d/stderr"
      rc=$? ;;
    *) # shellcheck disable=SC2086 # opts: several words
      oclgrind $opts --log "$d/oclgrind.log" "$bin" "$@" -q -o "$d/out.exr" > "$d/stdout" 2> "$d/stderr"
      rc=$? ;;
  esac
  why=""
  [ $rc -eq 0 ] || why="exit $rc: $(head -n 3 "$d/stderr")"
  [ -z "$why" ] && [ -s "$d/oclgrind.log" ] && why="oclgrind reported: $(grep -v '^\s*$' "$d/oclgrind.log" | head -n 8)"
  [ -z "$why" ] && ! cmp -s "$d/stderr" "$tmp/ref-$key.err" && why="stderr differs from PoCL's: $(head -n 3 "$d/stderr")"
  [ -z "$why" ] && ! cmp -s "$d/out.exr" "$ref" && why="output differs from PoCL's ($("$bin" info "$d/out.exr" | grep -i filled) vs $("$bin" info "$ref" | grep -i filled))"
  if [ -n "$why" ]; then echo "$label [oclgrind $opts] clvox $*: $why"; return 1; fi
  return 0
}

M=$meshes
# Every mode; closed (cow, cross) and open (cube-ouvert, corner_with_hole,
# elephant-with-holes: winding caps) meshes; ray axes x, y, z.
cases="
$M/cow.off -r 16 --inside parity
$M/cow.off -r 16 --axis y
$M/cross.off -r 16 --axis z --inside winding-abs
$M/cube-ouvert.off -r 16
$M/cube-ouvert.off -r 12 --axis y
$M/corner_with_hole.off -r 12 --axis z
$M/elephant-with-holes.off -r 12
$M/cow.off -r 16 --method tetra
$M/cow.off -r 12 --oversample 2 --axis z
$M/cube-ouvert.off -r 8 --oversample 3,2
$M/cow.off -r 12 --oversample 2 --stochastic --seed 7 --axis y
$M/cow.off -r 8 --palette planar10 --samples 4,4
$M/cube-ouvert.off -r 6 --palette binary --samples 4,2 --stochastic
$M/cow.off -r 16 --mode surface
$M/corner_with_hole.off -r 12 --mode surface
$M/cow.off -r 16 --mode conservative --axis y
$M/cube-ouvert.off -r 12 --mode conservative --method tetra
"
# run_cases LABEL OPTS CASES: check_case on each line of CASES (word
# splitting of each line is what we want: no spaces in the arguments)
run_cases() {
  rc_label=$1; rc_opts=$2; old_ifs=$IFS; IFS='
'
  for line in $3; do
    IFS=$old_ifs
    # shellcheck disable=SC2086
    if check_case "$rc_label" "$rc_opts" $line; then pass; else failed=$((failed + 1)); fi
    IFS='
'
  done
  IFS=$old_ifs
}
start=$(date +%s)
# Last, PoCL itself with work-groups of 1 (the results must not depend on
# the local size; Oclgrind above ran them at 16 and at its default).
for opts in "--data-races --check-api" "--max-wgsize 16" "pocl-local=1"; do
  run_cases case "$opts" "$cases"
done
echo "cases: $((passed + failed)) runs (oclgrind twice, PoCL local size 1 once) in $(($(date +%s) - start)) s"

# The float build (devices without fp64: CLVOX_KERNEL_FLOAT=1) under
# Oclgrind, in every mode (winding, coverage and palette, on cubic voxels
# and others, with the host deciding the points its float bounds cannot
# settle): the same bytes as the double
# kernels on PoCL (tests/test_float_kernels.c compares them on PoCL).
float_cases="
$M/cow.off -r 16 --inside parity
$M/cube-ouvert.off -r 12 --inside parity --axis y
$M/cow.off -r 16 --method tetra
$M/corner_with_hole.off -r 12 --mode surface
$M/cow.off -r 16 --mode conservative --method tetra --axis z
$M/elephant-with-holes.off -r 12
$M/elephant-with-holes.off --dims 14,11,9
$M/cube-ouvert.off -r 16
$M/cube-ouvert.off --dims 12,10,8 --oversample 2 --axis y
$M/cross.off -r 16 --axis z --inside winding-abs
$M/cow.off -r 12 --oversample 2 --axis z
$M/cube-ouvert.off -r 8 --oversample 3,2
$M/cow.off -r 12 --oversample 2 --stochastic --seed 7 --axis y --inside parity
$M/cube-ouvert.off -r 8 --palette planar10 --samples 4,4
$M/cow.off -r 6 --palette binary --samples 4,2 --stochastic --axis z
"
run_cases float "float:--data-races --check-api" "$float_cases"

# The caps' block lattice (kernels/winding_lattice.h), which runs only from
# 192 voxels on unless CLVOX_WINDING_LATTICE=1: the same bytes, in double
# and in float.
export CLVOX_WINDING_LATTICE=1
if check_case lattice "--data-races --check-api" "$M/elephant-with-holes.off" -r 16; then pass; else failed=$((failed + 1)); fi
if check_case lattice-float "float:--data-races --check-api" "$M/elephant-with-holes.off" -r 16 --axis z; then pass; else
  failed=$((failed + 1))
fi
unset CLVOX_WINDING_LATTICE

# The negative checks: a broken kernel must fail a case (the cache off, so
# the broken build is not kept nor an earlier one taken).
for k in 1 2; do
  if CLVOX_CACHE_DIR=off check_case broken-$k "--data-races --check-api --build-options -DCLVOX_TEST_BROKEN_KERNEL=$k" \
       "$M/cube-ouvert.off" -r 8 > "$tmp/broken-$k.txt"; then
    fail "a kernel built with CLVOX_TEST_BROKEN_KERNEL=$k passed the check"
  elif ! grep -q "oclgrind reported: .*\(Invalid write\|data race\)" "$tmp/broken-$k.txt"; then
    fail "CLVOX_TEST_BROKEN_KERNEL=$k failed, but not by oclgrind's report: $(head -c 400 "$tmp/broken-$k.txt")"
  else
    pass
  fi
done
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
