#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# ThreadSanitizer over the code that runs host threads of its own: the
# partition, the mesh report and the soup's grid passes (src/core/parallel.c),
# the cast's speculation, the EXR writer's encoders, the devices of a set
# (src/schedule.c), the winding
# preparation started ahead (clvox_mesh_prepare_winding), `clvox instances`'
# scorer and `clvox batch` loading the next mesh ahead (src/cli/cli_batch.c) --
# batch runs to the end, cut short by SIGTERM and with --skip-existing. Every
# process writes its reports to build/tsan/reports.*; a check passes when it
# exits as expected and no report appeared. Not part of `make test` (about
# 25 minutes on 2 cores).
#   scripts/check_threads.sh            # builds CONFIG=tsan, then runs
set -u
cd "$(dirname "$0")/.." || exit 1
here=$PWD
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
export CLVOX_CACHE_DIR="${CLVOX_CACHE_DIR:-$here/build/clvox-cache}"
export CLVOX_TEST_TMP="$here/build/tsan/test-tmp"
export CLVOX_BIN="$here/build/tsan/clvox"
mkdir -p "$POCL_CACHE_DIR" "$CLVOX_TEST_TMP"
make CONFIG=tsan -j2 tests >/dev/null || { echo "build failed"; echo "0 passed, 1 failed"; exit 1; }
[ -f data/meshes/armadillo.off ] || sh scripts/fetch_meshes.sh >/dev/null
rep="$here/build/tsan/reports"
export TSAN_OPTIONS="halt_on_error=0 log_path=$rep"
passed=0 failed=0
# check NAME EXPECTED_RC COMMAND...
check() {
  local name=$1 want=$2
  shift 2
  rm -f "$rep".*
  "$@" >"$CLVOX_TEST_TMP/$name.log" 2>&1
  local rc=$? n
  n=$(cat "$rep".* 2>/dev/null | grep -c 'WARNING: ThreadSanitizer')
  if [ "$rc" -eq "$want" ] && [ "$n" -eq 0 ]; then
    passed=$((passed + 1)); echo "  ok    $name"
  else
    failed=$((failed + 1)); echo "  FAIL  $name (exit $rc, want $want; $n reports)"
    cat "$rep".* 2>/dev/null | head -n 40
  fi
}
for t in test_winding_prep test_partition test_mesh test_mesh_report test_mesh_native test_exr test_instances test_cli \
  test_batch; do
  check "$t" 0 "build/tsan/tests/$t"
done
# The scheduler's device threads and the writer (src/schedule.c): two PoCL
# devices in one run, a device failing, a cancelled run.
check test_devices 0 env POCL_DEVICES="basic basic" build/tsan/tests/test_devices --child "basic basic"

out="$CLVOX_TEST_TMP/batch"
rm -rf "$out" && mkdir -p "$out"
check batch-all 0 "$CLVOX_BIN" batch --dir data/meshes -r 32 -o "$out/{n}.exr" -q --json
rm -rf "$out" && mkdir -p "$out"
# SIGTERM, not SIGINT: a background job of a non-interactive shell inherits
# SIGINT ignored, and clvox keeps an inherited SIG_IGN (so that nohup works).
cut_short() { # a batch cut short by SIGTERM: exit 130, no temporary file left
  "$CLVOX_BIN" batch --dir data/meshes -r 96 -o "$out/{n}.exr" -q &
  local pid=$!
  sleep 4
  kill -TERM "$pid"
  wait "$pid"
  local rc=$?
  [ -z "$(find "$out" -type f ! -name '*.exr')" ] || return 99
  return $rc
}
check batch-sigint 130 cut_short
check batch-skip-existing 0 "$CLVOX_BIN" batch --dir data/meshes -r 48 -o "$out/{n}.exr" --skip-existing -q --json
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
