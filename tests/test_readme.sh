#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# The commands the documentation shows, run as a user would: every command
# of README.md's indented code blocks (its Python block as one script) and
# the EXAMPLES that `clvox --help` ends with, each in a fresh temporary
# directory (README: data/ linked to the repository's data/, so
# data/meshes/... resolves; --help: the bundled default mesh, copied in as
# default.obj for the batch example's *.obj) against the built binary:
# `build/clvox` becomes $CLVOX_BIN (default build/$CONFIG/clvox). A command
# that exits non-zero is a failure. Commands that need root, the network or
# a GPU are skipped by the explicit list below, each with its reason. The
# Makefile copies this script to build/$CONFIG/tests/test_readme;
# tests/run_tests.sh runs it. Ends with one "N passed, N failed" line.
set -u
here=$(cd "$(dirname "$0")" && pwd)          # build/CONFIG/tests
build=$(dirname "$here")
repo=$(cd "$build/../.." && pwd)
bin=${CLVOX_BIN:-$build/clvox}
tmp="${CLVOX_TEST_TMP:-$repo/build/test-tmp}/readme"
passed=0; failed=0
if [ ! -x "$bin" ]; then echo "FAIL: no clvox binary at $bin (run make)"; echo "0 passed, 1 failed"; exit 1; fi
rm -rf "$tmp"; mkdir -p "$tmp/readme" "$tmp/help" || exit 1
ln -s "$repo/data" "$tmp/readme/data"
cp "$repo/tests/data/default.obj" "$tmp/help/default.obj"

# skip_reason LINE: why LINE is not run, or nothing. The explicit list.
skip_reason() {
  case "$1" in
    "scripts/setup.sh && make test"*) echo "runs the whole suite this test is part of (and setup.sh needs root and the network)" ;;
    *"pip install"*) echo "pip install needs the network (PyPI); the Python block below runs against the package built here" ;;
    *"--device gpu"*) echo "needs a GPU" ;;
    *"import matplotlib"*) echo "needs matplotlib, which clvox does not depend on" ;;
  esac
}

# run_cmd DIR LINE: one shell command in DIR.
run_cmd() {
  dir=$1; line=$2
  why=$(skip_reason "$line")
  if [ -n "$why" ]; then echo "SKIP: $line  -- $why"; return; fi
  # The quick start builds first; here the build under test is given.
  case "$line" in
    "scripts/setup.sh && make && "*)
      echo "note: '$line' runs without its 'scripts/setup.sh && make &&' (needs root and the network; the build is given)"
      line=${line#"scripts/setup.sh && make && "} ;;
  esac
  cmd=$(printf '%s\n' "$line" | sed "s#build/clvox#\"$bin\"#g")
  n=$((passed + failed + 1))
  if (cd "$dir" && sh -c "$cmd") > "$tmp/cmd$n.out" 2>&1; then
    passed=$((passed + 1)); echo "ok: $line"
  else
    rc=$?; failed=$((failed + 1)); echo "FAIL (exit $rc): $line"; tail -n 5 "$tmp/cmd$n.out"
  fi
}

# The interpreter and the cffi extension, as tests/test_python.sh builds it.
python_ready() {
  case "${CONFIG:-release}" in release|debug) ;; *) echo "the sanitizer runtime is not loaded into python (CONFIG=${CONFIG})"; return 1 ;; esac
  py=""
  for c in ${CLVOX_PYTHON:-} "$repo/build/venv-formats/bin/python" /usr/bin/python3 python3; do
    if "$c" -c "import cffi, numpy" >/dev/null 2>&1; then py=$c; break; fi
  done
  [ -n "$py" ] || { echo "no python3 with cffi and numpy (run scripts/setup.sh)"; return 2; }
  mkdir -p "$tmp/py/clvox" && cp "$repo"/python/clvox/*.py "$tmp/py/clvox/" || return 2
  if ! CLVOX_LIB="$build/libclvox.a" CLVOX_INCLUDE="$repo/include" "$py" "$repo/python/build_clvox.py" "$tmp/py/tmp" \
       > "$tmp/py/build.log" 2>&1; then tail -n 5 "$tmp/py/build.log"; echo "building the cffi extension failed"; return 2; fi
  cp "$tmp"/py/tmp/clvox/_clvox*.so "$tmp/py/clvox/" || return 2
  return 0
}

# README.md: indented code blocks (4 spaces after a blank line), one block
# per line of output, lines joined by a tab.
blocks=$(awk '
  /^    / && (inblock || prev == "") { sub(/^    /, ""); block = inblock ? block "\t" $0 : $0; inblock = 1; prev = $0; next }
  { if (inblock) print block; inblock = 0; block = ""; prev = $0 }
  END { if (inblock) print block }' "$repo/README.md")
[ -n "$blocks" ] || { echo "FAIL: no code blocks found in README.md"; failed=$((failed + 1)); }
tab=$(printf '\t')
printf '%s\n' "$blocks" > "$tmp/blocks.txt"
while IFS= read -r block; do
  [ -n "$block" ] || continue
  case "$block" in
    "import "*|"from "*)  # Python: one script, lines on the skip list left out
      script="$tmp/readme/block.py"; : > "$script"
      printf '%s\n' "$block" | tr "$tab" '\n' | while IFS= read -r l; do
        why=$(skip_reason "$l")
        if [ -n "$why" ]; then echo "SKIP: $l  -- $why" >&2; else printf '%s\n' "$l" >> "$script"; fi
      done
      python_ready > "$tmp/py-ready.txt"; prc=$?; msg=$(cat "$tmp/py-ready.txt")
      if [ $prc -eq 1 ]; then echo "SKIP: README's Python block -- $msg"; continue; fi
      if [ $prc -ne 0 ]; then echo "FAIL: README's Python block: $msg"; failed=$((failed + 1)); continue; fi
      if (cd "$tmp/readme" && PYTHONPATH="$tmp/py" PYTHONDONTWRITEBYTECODE=1 "$py" block.py) > "$tmp/py.out" 2>&1; then
        passed=$((passed + 1)); echo "ok: README's Python block ($(grep -c . "$script") lines)"
      else
        failed=$((failed + 1)); echo "FAIL: README's Python block"; tail -n 10 "$tmp/py.out"
      fi ;;
    *)
      printf '%s\n' "$block" | tr "$tab" '\n' > "$tmp/lines.txt"
      while IFS= read -r l; do
        case "$l" in ""|"#"*) continue ;; esac
        run_cmd "$tmp/readme" "$l"
      done < "$tmp/lines.txt" ;;
  esac
done < "$tmp/blocks.txt"

# clvox --help's EXAMPLES: "  clvox ..." lines after the EXAMPLES heading
# (the command ends where two spaces start its description).
"$bin" --help | awk '/^EXAMPLES/ { on = 1; next } on && /^  clvox / { sub(/^  /, ""); sub(/  +[^ ].*$/, ""); print }' \
  > "$tmp/help.txt"
[ -s "$tmp/help.txt" ] || { echo "FAIL: no EXAMPLES in clvox --help"; failed=$((failed + 1)); }
while IFS= read -r l; do
  run_cmd "$tmp/help" "$(printf '%s' "$l" | sed 's#^clvox #build/clvox #')"
done < "$tmp/help.txt"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
