#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# The Python package's tests (python/tests, pytest), run by tests/run_tests.sh
# like the C test programs: the Makefile copies this script to
# build/$CONFIG/tests/test_python. It compiles the cffi extension against
# build/$CONFIG/libclvox.a into build/$CONFIG/python (about 3 s), runs pytest
# there and ends with one "N passed, N failed" line (python/tests/conftest.py).
# The interpreter: the first of $CLVOX_PYTHON, build/venv-formats/bin/python,
# /usr/bin/python3 (Debian's, with the python3-cffi/-numpy/-pytest packages
# scripts/setup.sh installs) and python3 that imports cffi, numpy and pytest.
# build/venv-formats (scripts/setup.sh: pynrrd and trimesh from PyPI, made
# with --system-site-packages from Debian's python3) adds trimesh to Debian's
# packages, so test_trimesh.py runs; a venv made from another python3 (no
# pytest) is passed over, and without trimesh those tests are skipped (the
# line below says which interpreter ran and whether trimesh was there).
set -u
here=$(cd "$(dirname "$0")" && pwd)          # build/CONFIG/tests
build=$(dirname "$here")
repo=$(cd "$build/../.." && pwd)
case "${CONFIG:-release}" in
  release|debug) ;;
  *) echo "SKIP python tests: CONFIG=${CONFIG} (the sanitizer runtime is not loaded into python)"
     echo "0 passed, 0 failed"; exit 0 ;;
esac
py=""
for c in ${CLVOX_PYTHON:-} "$repo/build/venv-formats/bin/python" /usr/bin/python3 python3; do
  if "$c" -c "import cffi, numpy, pytest" >/dev/null 2>&1; then py=$c; break; fi
done
if [ -z "$py" ]; then
  echo "FAIL: no python3 with cffi, numpy and pytest (run scripts/setup.sh)"
  echo "0 passed, 1 failed"; exit 1
fi
out="$build/python"
rm -rf "$out/clvox"
mkdir -p "$out/clvox"
cp "$repo"/python/clvox/*.py "$out/clvox/" || exit 1
if ! CLVOX_LIB="$build/libclvox.a" CLVOX_INCLUDE="$repo/include" "$py" "$repo/python/build_clvox.py" "$out/tmp" \
     > "$out/build.log" 2>&1; then
  tail -n 20 "$out/build.log"; echo "FAIL: building the cffi extension"; echo "0 passed, 1 failed"; exit 1
fi
cp "$out"/tmp/clvox/_clvox*.so "$out/clvox/" || exit 1
cd "$repo/python/tests" || exit 1
tmp="${CLVOX_TEST_TMP:-$build/test-tmp}"
mkdir -p "$tmp"
if "$py" -c "import trimesh" >/dev/null 2>&1; then tm=yes; else tm="no: test_trimesh.py skipped"; fi
echo "python tests: $py (trimesh: $tm)"
PYTHONPATH="$out" PYTHONDONTWRITEBYTECODE=1 CLVOX_LIB="$build/libclvox.a" CLVOX_INCLUDE="$repo/include" CLVOX_BIN="${CLVOX_BIN:-$build/clvox}" \
  "$py" -m pytest -q -p no:cacheprovider --basetemp="$tmp/pytest" .
