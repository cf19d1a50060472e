#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Writes the seeds of fuzz_read_npy, fuzz_read_nrrd and fuzz_read_binvox
# (tests/fuzz/seeds_read_*/): small volumes written by clvox itself in every
# mode each format holds, packed as tests/fuzz/fuzz_read.h reads an input
# (files joined by its separator, in the target's order of names).
# Usage: sh tests/fuzz/make_read_seeds.sh [build/release/clvox]
set -eu
BIN=${1:-build/release/clvox}
HERE=$(cd "$(dirname "$0")" && pwd)
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
SEP=$(printf '\n==CLVOX-FUZZ-NEXT-FILE==\n_')
SEP=${SEP%_}
# an octahedron, off-centre
printf 'OFF\n6 8 0\n1.1 0.1 0\n-0.9 0.1 0\n0.1 1.1 0\n0.1 -0.9 0\n0.1 0.1 1\n0.1 0.1 -1\n3 0 2 4\n3 2 1 4\n3 1 3 4\n3 3 0 4\n3 2 0 5\n3 1 2 5\n3 3 1 5\n3 0 3 5\n' > "$T/m.off"
pack() { # OUT FILE... (a missing file packs as empty)
    out=$1; shift
    first=1
    for f in "$@"; do
        [ $first = 1 ] || printf '%s' "$SEP"
        first=0
        [ -f "$T/$f" ] && cat "$T/$f"
    done > "$out"
    return 0
}
vox() { # NAME OUTFILE ARGS...
    rm -f "$T"/fz.* "$T"/fz
    name=$1; out=$2; shift 2
    "$BIN" "$T/m.off" -r 6 --box -1,-1,-1,1.2,1.2,1.2 -q "$@" -o "$T/$out"
}
mkdir -p "$HERE/seeds_read_npy" "$HERE/seeds_read_nrrd" "$HERE/seeds_read_binvox"
for mode in occ cov both pal; do
    case $mode in
    occ) a="";; cov) a="--oversample 2";; both) a="--oversample 2 --channels occupancy,coverage";;
    pal) a="--palette planar10";;
    esac
    for flag in "" --npy-bits --npy-float32 --npy-uint32; do
        # shellcheck disable=SC2086
        vox npy fz.npy $a $flag
        pack "$HERE/seeds_read_npy/$mode${flag#--npy}.bin" fz.npy fz.json fz.coverage.npy fz.score.npy fz.element.npy
    done
    for c in none zip; do
        # shellcheck disable=SC2086
        vox nrrd fz.nrrd $a --compression $c
        if [ $c = none ]; then # a detached header over the main file's data
            ln=$(grep -an -m1 '^$' "$T/fz.nrrd" | cut -d: -f1)
            n=$(head -n "$ln" "$T/fz.nrrd" | wc -c)
            head -n $((ln - 1)) "$T/fz.nrrd" | grep -av '^clvox_set:=' > "$T/fz.nhdr"
            printf 'data file: fz.raw\n' >> "$T/fz.nhdr"
            tail -c +$((n + 1)) "$T/fz.nrrd" > "$T/fz.raw"
        fi
        pack "$HERE/seeds_read_nrrd/$mode-$c.bin" fz.nrrd fz.coverage.nrrd fz.score.nrrd fz.element.nrrd fz.nhdr fz.raw
    done
done
vox binvox fz.binvox
pack "$HERE/seeds_read_binvox/occ.bin" fz.binvox
"$BIN" "$T/m.off" -r 12 --box -1,-1,-1,1.2,1.2,1.2 -q -o "$T/fz.binvox"
pack "$HERE/seeds_read_binvox/occ12.bin" fz.binvox
