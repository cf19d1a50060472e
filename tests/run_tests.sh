#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Runs every test program in $1/tests and adds up their "N passed, N failed"
# lines. Usage: sh tests/run_tests.sh build/release
set -u
build=${1:-build/release}
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here" || exit 1
# The real meshes (data/meshes, git-ignored) come from Debian's libcgal-demo.
if [ -z "${CLVOX_QUICK:-}" ] && [ ! -f data/meshes/armadillo.off ]; then
  sh scripts/fetch_meshes.sh || echo "warning: could not fetch meshes"
fi
# PoCL needs a writable kernel cache, else it reports no device at all.
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
mkdir -p "$POCL_CACHE_DIR"
# The kernel program's binary between processes (src/core/program_cache.c): in
# the build tree, not the user's ~/.cache.
export CLVOX_CACHE_DIR="${CLVOX_CACHE_DIR:-$here/build/clvox-cache}"
export CLVOX_TEST_TMP="${CLVOX_TEST_TMP:-$here/build/test-tmp}"
mkdir -p "$CLVOX_TEST_TMP"
export CLVOX_BIN="$here/$build/clvox"
export LSAN_OPTIONS="suppressions=$here/tests/lsan.supp:print_suppressions=0"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
passed=0; failed=0; broken=""
# run_one NAME [VAR=VALUE] PROGRAM: runs it, adds its summary line up
run_one() {
  name=$1; shift
  start=$(date +%s)
  log="$CLVOX_TEST_TMP/$name.log"
  env "$@" > "$log" 2>&1
  rc=$?
  line=$(grep -E '^[0-9]+ passed, [0-9]+ failed$' "$log" | tail -n 1)
  end=$(date +%s)
  if [ -z "$line" ]; then
    echo "  $name: no summary line (exit $rc), counted as 1 failure"; tail -n 20 "$log"
    failed=$((failed + 1)); broken="$broken $name"; return
  fi
  p=${line%% passed*}; f=${line#*passed, }; f=${f%% failed}
  if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then f=1; fi
  passed=$((passed + p)); failed=$((failed + f))
  echo "  $name: $line ($((end - start)) s)"
  if [ "$f" -ne 0 ]; then grep -E 'FAIL|ERROR|Sanitizer|runtime error' "$log" | head -n 20; broken="$broken $name"; fi
}
for t in "$build"/tests/test_*; do
  [ -x "$t" ] || continue
  case "$t" in *.d) continue;; esac
  run_one "$(basename "$t")" "$t"
done
# The kernels' float path (devices without fp64) on PoCL: built with
# -DCLVOX_NO_FP64 (CLVOX_KERNEL_FLOAT=1, src/core/context.c), test_winding again;
# it says "skipped (the device has no double)" where it runs in float.
t="$build/tests/test_winding"
if [ -z "${CLVOX_QUICK:-}" ] && [ -x "$t" ]; then
  run_one test_winding_float CLVOX_KERNEL_FLOAT=1 "$t"
  if ! grep -q 'skipped (the device has no double)' "$CLVOX_TEST_TMP/test_winding_float.log"; then
    echo "  test_winding_float: the kernels did not run in float, counted as 1 failure"
    failed=$((failed + 1)); broken="$broken test_winding_float"
  fi
fi
# The raster methods' and the ray method's exact float paths against their
# oracles (GMP clipping, tetra == ray), in float.
for name in test_surface test_tetra; do
  t="$build/tests/$name"
  if [ -z "${CLVOX_QUICK:-}" ] && [ -x "$t" ]; then run_one "${name}_float" CLVOX_KERNEL_FLOAT=1 "$t"; fi
done
[ -n "$broken" ] && echo "failing:$broken"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
