#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Mesh load throughput (issue 10), not a test: MB/s of clvox_mesh_load with
# the native binary PLY / binary STL readers against OpenMesh's
# (CLVOX_MESH_READER=openmesh), page cache warm, best of R runs (default 10;
# OpenMesh best of 3). "load": the whole clvox_mesh_load (including
# build_mesh: validation, edge and duplicate analysis for the report, the
# same for both readers); "reader": the load up to build_mesh (mmap, checks,
# parse), where MB/s = file size / seconds.
#
#   scripts/bench/bench_load.sh [--repeat R]
#
# Files: data/meshes/armadillo_s2.ply (832 k triangles) and armadillo_s3.ply
# (3.3 M; made by scripts/bench/subdivide.c as in bench_coverage.sh when absent),
# binary STLs of both, and armadillo_s2 as ASCII OBJ, OFF, PLY and STL
# (%.9g coordinates: the same floats), all written to build/bench/ by
# bench_load. For OBJ and OFF "OpenMesh" is the same (native) reader; ASCII
# PLY (float x y z) and ASCII STL (one solid) are read natively, or by
# OpenMesh with CLVOX_MESH_READER=openmesh.
# Markdown to stdout and build/bench/load.md.
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"
repeat=10
while [ $# -gt 0 ]; do
  case "$1" in
    --repeat) repeat=${2:?--repeat needs a number}; shift ;;
    -h|--help) sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench_load.sh: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done
make -s -j2 CONFIG=release bench-tools >&2   # build/release/bench/{bench_load,subdivide}
mkdir -p build/bench
tools=build/release/bench
m=data/meshes
if [ ! -f $m/armadillo_s3.ply ] && [ -f $m/armadillo_s2.ply ]; then
  $tools/subdivide $m/armadillo.off 3 $m/armadillo_s3.ply >&2
fi
files=()
for s in s2 s3; do
  [ -f $m/armadillo_$s.ply ] || continue
  files+=($m/armadillo_$s.ply)
  [ -f build/bench/armadillo_$s.stl ] || $tools/bench_load --stl $m/armadillo_$s.ply build/bench/armadillo_$s.stl
  files+=(build/bench/armadillo_$s.stl)
done
if [ -f $m/armadillo_s2.ply ]; then
  for f in obj off ply stl; do
    [ -f build/bench/armadillo_s2_ascii.$f ] || $tools/bench_load --ascii $f $m/armadillo_s2.ply build/bench/armadillo_s2_ascii.$f
    files+=(build/bench/armadillo_s2_ascii.$f)
  done
fi
{ echo "Load throughput, $(nproc) cores, $(date -u +%F)"; echo
  $tools/bench_load -r "$repeat" "${files[@]}"; } | tee build/bench/load.md
