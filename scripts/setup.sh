#!/bin/sh
# Installs the Debian 12 packages clvox needs to build, run and test.
#   scripts/setup.sh           build + test dependencies
#   scripts/setup.sh --peers   also VTK, OpenVDB and NumPy for scripts/bench.sh --peers
#   scripts/setup.sh --with-blender   also Blender, for scripts/blender_instances.py
#                              and tests/test_blender.c (or CLVOX_WITH_BLENDER=1)
# Idempotent: when everything is present it only runs dpkg-query. When not
# root it uses sudo if that works without a password, else it prints the
# exact apt-get line to run and exits 1.
set -eu

pkgs="build-essential pkg-config ca-certificates time \
pocl-opencl-icd ocl-icd-opencl-dev opencl-headers clinfo \
libopenexr-dev openexr libopenmesh-dev libpng-dev libgmp-dev"
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
[ "$peers" -eq 1 ] && pkgs="$pkgs python3 python3-numpy python3-vtk9 python3-openvdb"
# Debian's Blender 3.4 (about 140 packages; Cycles renders on the CPU).
[ "$blender" -eq 1 ] && pkgs="$pkgs blender"

if ! command -v dpkg-query >/dev/null 2>&1 || ! command -v apt-get >/dev/null 2>&1; then
  echo "setup.sh: needs a Debian-based system (dpkg/apt-get); install by hand: $pkgs" >&2
  exit 1
fi

missing=""
for p in $pkgs; do
  st=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  case "$st" in *" installed") ;; *) missing="$missing $p" ;; esac
done
if [ -z "$missing" ]; then
  echo "setup.sh: all packages present"
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
echo "setup.sh: done"
