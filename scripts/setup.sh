#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Installs the Debian 12 packages clvox needs to build, run and test.
#   scripts/setup.sh           build + test dependencies (Python: the binding in python/ and its tests)
#   scripts/setup.sh --peers   also VTK, OpenVDB and NumPy for scripts/bench/bench.sh --peers
#   scripts/setup.sh --with-blender   also Blender, for scripts/tools/blender_instances.py
#                              and tests/test_blender.c (or CLVOX_WITH_BLENDER=1)
# Idempotent: when everything is present it only runs dpkg-query. When not
# root it uses sudo if that works without a password, else it prints the
# exact apt-get line to run and exits 1.
set -eu

pkgs="build-essential pkg-config ca-certificates time \
pocl-opencl-icd ocl-icd-opencl-dev opencl-headers clinfo clang llvm oclgrind zlib1g-dev \
libopenexr-dev openexr libopenmesh-dev libassimp-dev libpng-dev libgmp-dev libopenvdb-dev libboost-dev python3-openvdb \
python3 python3-dev python3-cffi python3-numpy python3-pytest python3-setuptools python3-wheel python3-pip python3-venv \
slurmctld slurmd slurm-client munge"
peers=0
blender=0
[ "${CLVOX_WITH_BLENDER:-0}" = 1 ] && blender=1
for arg in "$@"; do
  case "$arg" in
    --peers) peers=1 ;;
    --with-blender) blender=1 ;;
    -h|--help) sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "setup.sh: unknown option '$arg' (try --help)" >&2; exit 2 ;;
  esac
done
[ "$peers" -eq 1 ] && pkgs="$pkgs python3-vtk9"
# Debian's Blender 3.4 (about 140 packages; Cycles renders on the CPU).
[ "$blender" -eq 1 ] && pkgs="$pkgs blender"

if ! command -v dpkg-query >/dev/null 2>&1 || ! command -v apt-get >/dev/null 2>&1; then
  echo "setup.sh: needs a Debian-based system (dpkg/apt-get); install by hand: $pkgs" >&2
  exit 1
fi

# The independent readers of tests/test_formats.c that Debian 12 does not
# package (pynrrd for NRRD, trimesh's binvox loader): PyPI, pinned, into a
# virtual environment in build/ that sees Debian's NumPy.
root=$(cd "$(dirname "$0")/.." && pwd)
python_readers() {
  venv="$root/build/venv-formats"
  if "$venv/bin/python" -c "import nrrd, trimesh" >/dev/null 2>&1; then return 0; fi
  echo "setup.sh: installing pynrrd and trimesh into build/venv-formats"
  # Debian's python3 (not another one first on PATH): the venv then sees its
  # numpy, cffi and pytest, and tests/test_python.sh runs the Python tests in it.
  py3=/usr/bin/python3; [ -x "$py3" ] || py3=python3
  "$py3" -m venv --system-site-packages "$venv" && \
    "$venv/bin/pip" install -q --disable-pip-version-check pynrrd==1.1.3 trimesh==5.2.0 || {
      echo "setup.sh: pip install of pynrrd/trimesh failed" >&2; return 1; }
}

# The Python package's optional CPU driver from PyPI (python/README.md "PoCL from PyPI"):
# with it in build/venv-formats, python/tests/test_packaging.py checks that the wheel's PoCL
# gives the system PoCL's voxels; without it (offline, 58 MB) that test is skipped.
python_pocl() {
  venv="$root/build/venv-formats"
  if "$venv/bin/python" -c "import pocl_binary_distribution" >/dev/null 2>&1; then return 0; fi
  echo "setup.sh: installing pocl-binary-distribution into build/venv-formats (optional)"
  "$venv/bin/pip" install -q --disable-pip-version-check pocl-binary-distribution==3.0 ||
    echo "setup.sh: pip install of pocl-binary-distribution failed; its test will be skipped" >&2
  return 0
}

missing=""
for p in $pkgs; do
  st=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  case "$st" in *" installed") ;; *) missing="$missing $p" ;; esac
done
if [ -z "$missing" ]; then
  echo "setup.sh: all packages present"
  python_readers || exit 1
  python_pocl
  exit 0
fi

echo "setup.sh: installing:$missing"
if [ "$(id -u)" -eq 0 ]; then
  sudo=""
elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
  sudo="sudo -n"
else
  echo "setup.sh: not root and no password-less sudo; run as root:" >&2
  echo "  apt-get update && apt-get install -y --no-install-recommends$missing" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
log=$(mktemp "${TMPDIR:-/tmp}/clvox-setup.XXXXXX")
if ! { $sudo apt-get update -qq && \
       $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $missing; } >"$log" 2>&1; then
  tail -n 20 "$log" >&2
  rm -f "$log"
  echo "setup.sh: apt-get failed" >&2
  exit 1
fi
rm -f "$log"
python_readers || exit 1
python_pocl
echo "setup.sh: done"
