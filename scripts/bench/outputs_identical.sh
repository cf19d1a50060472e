#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Byte-identity check for refactors: runs a fixed set of clvox commands (every
# mode, inside test, method and output format, on closed and open CGAL meshes,
# plus batch, convert, info, preview, mesh and instances) and writes the
# SHA-256 of every file they produce to OUTDIR/sums.txt. Run it with the
# build before and after a change and compare:
#   scripts/bench/outputs_identical.sh build/clvox /tmp/before
#   ... change, rebuild ...
#   scripts/bench/outputs_identical.sh build/clvox /tmp/after
#   diff /tmp/before/sums.txt /tmp/after/sums.txt && echo identical
# Needs the CGAL meshes (scripts/fetch_meshes.sh). Takes about a minute.
set -euo pipefail
if [ $# -ne 2 ]; then echo "usage: $0 CLVOX_BIN OUTDIR" >&2; exit 2; fi
bin=$(readlink -f "$1"); out=$2
root=$(cd "$(dirname "$0")/../.." && pwd)
m="$root/data/meshes"
for f in armadillo.off elephant-with-holes.off fandisk.off cube-ouvert.off; do
  [ -f "$m/$f" ] || { echo "$0: $m/$f missing: run scripts/fetch_meshes.sh" >&2; exit 2; }
done
rm -rf "$out"; mkdir -p "$out/v"; cd "$out/v"
export CLVOX_CACHE_DIR="$out/cache"
n=0
run() {  # run NAME ARGS...: one clvox command, its stdout dropped (timings)
  local name=$1; shift
  n=$((n + 1))
  if ! "$bin" "$@" -q > /dev/null 2> "$out/$name.err"; then
    echo "$0: $name failed: clvox $*" >&2; cat "$out/$name.err" >&2; exit 1
  fi
}
closed=$m/armadillo.off; open=$m/elephant-with-holes.off
for mesh in closed open; do
  f=${!mesh}
  run ${mesh}_solid       "$f" -r 64 -o ${mesh}_solid.exr
  run ${mesh}_parity      "$f" -r 64 --inside parity -o ${mesh}_parity.exr
  run ${mesh}_abs         "$f" -r 64 --inside winding-abs -o ${mesh}_abs.exr
  run ${mesh}_weld        "$f" -r 48 --weld 0.001 -o ${mesh}_weld.exr
  run ${mesh}_tetra       "$f" -r 64 --method tetra -o ${mesh}_tetra.exr
  run ${mesh}_tetra_bbox  "$f" -r 48 --method tetra --tetra-origin bbox -o ${mesh}_tetra_bbox.exr
  run ${mesh}_surface     "$f" -r 64 --mode surface -o ${mesh}_surface.exr
  run ${mesh}_cons        "$f" -r 64 --mode conservative -o ${mesh}_cons.exr
  run ${mesh}_axis_y      "$f" -r 64 --axis y --depth 3 --leaf 8 --slab 5 -o ${mesh}_axis_y.exr
  run ${mesh}_axis_z      "$f" --dims 40,50,30 --axis z --pad 2 -o ${mesh}_axis_z.exr
  run ${mesh}_vsize       "$f" --voxel-size 0.02 --box -0.5,-0.5,-0.5,0.5,0.5,0.5 -o ${mesh}_vsize.exr
  run ${mesh}_cov         "$f" -r 48 --oversample 3 -o ${mesh}_cov.exr
  run ${mesh}_cov_nm      "$f" -r 48 --oversample 2,5 --stochastic --seed 7 -o ${mesh}_cov_nm.exr
  run ${mesh}_thresh      "$f" -r 48 --oversample 4 --threshold 0.2 -o ${mesh}_thresh.exr
  run ${mesh}_both        "$f" -r 48 --oversample 2 --channels occupancy,coverage -o ${mesh}_both.exr
  run ${mesh}_pal_bin     "$f" -r 32 --palette binary -o ${mesh}_pal_bin.exr
  run ${mesh}_pal_p10     "$f" -r 32 --palette planar10 --metric outer -o ${mesh}_pal_p10.exr
  run ${mesh}_pal_p46     "$f" -r 24 --palette paper46 --metric inner --samples 9,8 --stochastic --seed 3 --channels element,score,coverage,occupancy -o ${mesh}_pal_p46.exr
  run ${mesh}_pal_short   "$f" -r 24 --palette paper78 --shortcut auto -o ${mesh}_pal_short.exr
  for c in none zip zips piz; do
    run ${mesh}_exr_$c    "$f" -r 48 --compression $c -o ${mesh}_exr_$c.exr
  done
  run ${mesh}_npy         "$f" -r 48 -o ${mesh}_npy.npy
  run ${mesh}_npy_bits    "$f" -r 48 --npy-bits -o ${mesh}_npy_bits.npy
  run ${mesh}_npy_cov     "$f" -r 32 --oversample 2 --channels occupancy,coverage --npy-float32 -o ${mesh}_npy_cov.npy
  run ${mesh}_npy_pal     "$f" -r 24 --palette planar10 --npy-uint32 -o ${mesh}_npy_pal.npy
  run ${mesh}_nrrd        "$f" -r 48 -o ${mesh}_nrrd.nrrd
  run ${mesh}_nrrd_raw    "$f" -r 48 --compression none --oversample 2 -o ${mesh}_nrrd_raw.nrrd
  run ${mesh}_nrrd_pal    "$f" -r 24 --palette planar10 -o ${mesh}_nrrd_pal.nrrd
  run ${mesh}_binvox      "$f" --dims 48,48,48 --box -1,-1,-1,1,1,1 -o ${mesh}_binvox.binvox
  run ${mesh}_vdb         "$f" -r 48 --oversample 2 -o ${mesh}_vdb.vdb
  run ${mesh}_like_nrrd   "$f" --like ${mesh}_nrrd.nrrd -o ${mesh}_like_nrrd.exr
  run ${mesh}_like_npy    "$f" --like ${mesh}_npy.json -o ${mesh}_like_npy.exr
  run ${mesh}_like_exr    "$f" --like ${mesh}_axis_z.exr --method tetra -o ${mesh}_like_exr.exr
done
run small_fandisk "$m/fandisk.off" -r 40 --mode conservative -o fandisk.exr
run small_open "$m/cube-ouvert.off" -r 40 -o cube_ouvert.exr
sub() {  # sub NAME ARGS...: a subcommand (they take no -q)
  local name=$1; shift
  n=$((n + 1))
  if ! "$bin" "$@" > /dev/null 2> "$out/$name.err"; then
    echo "$0: $name failed: clvox $*" >&2; cat "$out/$name.err" >&2; exit 1
  fi
}
# Other subcommands on what was written above.
for c in npy nrrd vdb; do
  sub convert_$c convert closed_cov.exr conv_cov.$c
done
sub convert_binvox2 convert closed_vsize.exr conv_vsize.npy --npy-bits
sub convert_pal convert closed_pal_p10.exr conv_pal.npy --channel element --npy-uint32
sub info info closed_pal_p10.exr --json
"$bin" info closed_pal_p10.exr > info.txt
"$bin" info closed_cov.exr --json | sed 's/"seconds":[^,}]*//g' > info_cov.json
sub preview preview closed_cov.exr -o preview.png
sub mesh mesh closed_pal_p10.exr -o pal_mesh.ply
sub mesh_ascii mesh open_pal_p46.exr -o pal_mesh_ascii.ply --ascii
sub instances instances closed_pal_p46.exr -o instances.csv
"$bin" palette show paper46 > palette_paper46.txt
"$bin" palette list > palette_list.txt
mkdir -p batch
run batch batch "$m/fandisk.off" "$m/cube-ouvert.off" "$m/armadillo.off" --dir batch -r 40 --format npy
rm -rf "$out/cache"
# A .vdb file carries a random UUID (bytes 22-57 of its header): hashed without it.
find . -type f | LC_ALL=C sort | while read -r f; do
  case $f in
    *.vdb) echo "$( (head -c 21 "$f"; tail -c +58 "$f") | sha256sum | cut -d' ' -f1)  $f (less its UUID)" ;;
    *) sha256sum "$f" ;;
  esac
done > "$out/sums.txt"
echo "$n runs, $(wc -l < "$out/sums.txt") files: $out/sums.txt"
