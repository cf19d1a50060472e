#!/bin/sh
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
# The kernel program's binary between processes (src/program_cache.c): in
# the build tree, not the user's ~/.cache.
export CLVOX_CACHE_DIR="${CLVOX_CACHE_DIR:-$here/build/clvox-cache}"
export CLVOX_TEST_TMP="${CLVOX_TEST_TMP:-$here/build/test-tmp}"
mkdir -p "$CLVOX_TEST_TMP"
export CLVOX_BIN="$here/$build/clvox"
export LSAN_OPTIONS="suppressions=$here/tests/lsan.supp:print_suppressions=0"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
passed=0; failed=0; broken=""
for t in "$build"/tests/test_*; do
  [ -x "$t" ] || continue
  case "$t" in *.d) continue;; esac
  name=$(basename "$t")
  start=$(date +%s)
  log="$CLVOX_TEST_TMP/$name.log"
  "$t" > "$log" 2>&1
  rc=$?
  line=$(grep -E '^[0-9]+ passed, [0-9]+ failed$' "$log" | tail -n 1)
  end=$(date +%s)
  if [ -z "$line" ]; then
    echo "  $name: no summary line (exit $rc), counted as 1 failure"; tail -n 20 "$log"
    failed=$((failed + 1)); broken="$broken $name"; continue
  fi
  p=${line%% passed*}; f=${line#*passed, }; f=${f%% failed}
  if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then f=1; fi
  passed=$((passed + p)); failed=$((failed + f))
  echo "  $name: $line ($((end - start)) s)"
  if [ "$f" -ne 0 ]; then grep -E 'FAIL|ERROR|Sanitizer|runtime error' "$log" | head -n 20; broken="$broken $name"; fi
done
[ -n "$broken" ] && echo "failing:$broken"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
