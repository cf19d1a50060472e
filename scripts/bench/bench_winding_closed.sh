#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Closed-mesh cost of the winding default against parity (issue 9: winding
# within 1.1x of parity's whole-process time), not a test:
#
#   scripts/bench/bench_winding_closed.sh [-r N] [--rounds K] [--base BIN] [MESH...]
#   scripts/bench/bench_winding_closed.sh --prep [--base-tree DIR] [--rounds K] [MESH...]
#
# For each mesh (default: armadillo_s3.ply, armadillo_s2.ply, bunny00.off in
# data/meshes) and each of K rounds (default 7), runs
#   BIN MESH -r N --inside {parity,winding} --no-progress -o TMP.exr
# under /usr/bin/time for this tree's build/release/clvox and, when --base
# is given, for that binary too, interleaved (the order of the runs turns
# round by round, so that a load change hits all of them alike). Prints per
# round the wall seconds and the winding / parity ratio, then the medians
# of those, of the CPU time (user + sys) and of the peak RSS, and the load
# average before and after (the machine may be shared: judge by it).
#
# --prep: the preparation alone instead (scripts/bench/bench_winding_prep.c, built
# against build/release/libclvox.a: 9 runs per mesh, median and minimum of
# wall and thread CPU), for this tree with CLVOX__PREP_BORROW (as the cast's
# speculation) and without, and with --base-tree DIR for DIR's
# build/release/libclvox.a and headers (another worktree, e.g. /work/main)
# the same two, K rounds interleaved.
set -euo pipefail
cd "$(dirname "$0")/../.."
N=512
K=7
BASE=""
PREP=0
BASE_TREE=""
MESHES=()
while [ $# -gt 0 ]; do
    case "$1" in
    -r) N="$2"; shift 2 ;;
    --rounds) K="$2"; shift 2 ;;
    --base) BASE="$2"; shift 2 ;;
    --prep) PREP=1; shift ;;
    --base-tree) BASE_TREE="$2"; shift 2 ;;
    -h | --help) sed -n '2,24p' "$0"; exit 0 ;;
    *) MESHES+=("$1"); shift ;;
    esac
done
[ ${#MESHES[@]} -gt 0 ] || MESHES=(data/meshes/armadillo_s3.ply data/meshes/armadillo_s2.ply data/meshes/bunny00.off)
if [ "$PREP" = 1 ]; then
    T=build/release/bench
    make -s -j2 CONFIG=release bench-tools
    PB=($T/bench_winding_prep_borrow $T/bench_winding_prep)
    PN=("this, borrowed" "this, copied")
    if [ -n "$BASE_TREE" ]; then
        make -s CONFIG=release bench-prep-base BENCH_BASE_TREE="$BASE_TREE"
        PB+=($T/bench_winding_prep_base_borrow $T/bench_winding_prep_base)
        PN+=("base, borrowed" "base, copied")
    fi
    echo "load before: $(cut -d' ' -f1-3 /proc/loadavg)"
    for mesh in "${MESHES[@]}"; do
        [ -f "$mesh" ] || { echo "skip $mesh: missing"; continue; }
        for ((r = 0; r < K; r++)); do
            for ((i = 0; i < ${#PB[@]}; i++)); do
                echo "round $r ${PN[$i]}: $("${PB[$i]}" "$mesh" 9)"
            done
        done
    done
    echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
    exit 0
fi
BINS=(build/release/clvox)
NAMES=(this)
if [ -n "$BASE" ]; then
    BINS+=("$BASE")
    NAMES+=(base)
fi
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$TMP/pocl}"
mkdir -p "$POCL_CACHE_DIR"
echo "load before: $(cut -d' ' -f1-3 /proc/loadavg)"
run() { # bin mode mesh -> "seconds rss_kb cpu_seconds" (wall to the ms: time's %e has 10 ms steps)
    local t0 t1
    t0=$(date +%s%N)
    /usr/bin/time -f "%M %U %S" -o "$TMP/t" "$1" "$3" -r "$N" --inside "$2" --no-progress -q -o "$TMP/x.exr" >/dev/null
    t1=$(date +%s%N)
    awk -v ns=$((t1 - t0)) '{printf "%.3f %s %.2f\n", ns / 1e9, $1, $2 + $3}' "$TMP/t"
}
median() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }
for mesh in "${MESHES[@]}"; do
    [ -f "$mesh" ] || { echo "skip $mesh: missing"; continue; }
    for b in "${BINS[@]}"; do for m in parity winding; do run "$b" $m "$mesh" >/dev/null; done; done # warm the caches (files, kernels)
    : >"$TMP/res"
    for ((r = 0; r < K; r++)); do
        line="round $r:"
        order=(0 1 2 3)
        [ $((r % 2)) -eq 1 ] && order=(3 2 1 0)
        declare -A T=()
        for o in "${order[@]}"; do
            bi=$((o / 2))
            [ "$bi" -lt ${#BINS[@]} ] || continue
            mode=$([ $((o % 2)) -eq 0 ] && echo parity || echo winding)
            read -r s m c < <(run "${BINS[$bi]}" "$mode" "$mesh")
            T["$bi.$mode"]=$s
            echo "${NAMES[$bi]} $mode $s $m $c" >>"$TMP/res"
        done
        for ((bi = 0; bi < ${#BINS[@]}; bi++)); do
            p=${T["$bi.parity"]}
            w=${T["$bi.winding"]}
            ratio=$(awk -v w="$w" -v p="$p" 'BEGIN {printf "%.3f", w / p}')
            echo "${NAMES[$bi]} ratio $ratio" >>"$TMP/res"
            line="$line  ${NAMES[$bi]} parity $p winding $w (x$ratio)"
        done
        unset T
        echo "$(basename "$mesh") $line"
    done
    for name in "${NAMES[@]}"; do
        mp=$(awk -v n="$name" '$1 == n && $2 == "parity" {print $3}' "$TMP/res" | median)
        mw=$(awk -v n="$name" '$1 == n && $2 == "winding" {print $3}' "$TMP/res" | median)
        mr=$(awk -v n="$name" '$1 == n && $2 == "ratio" {print $3}' "$TMP/res" | median)
        rp=$(awk -v n="$name" '$1 == n && $2 == "parity" {print $4}' "$TMP/res" | median)
        rw=$(awk -v n="$name" '$1 == n && $2 == "winding" {print $4}' "$TMP/res" | median)
        cp=$(awk -v n="$name" '$1 == n && $2 == "parity" {print $5}' "$TMP/res" | median)
        cw=$(awk -v n="$name" '$1 == n && $2 == "winding" {print $5}' "$TMP/res" | median)
        echo "$(basename "$mesh") $name: median parity $mp s, winding $mw s, median ratio $mr; CPU (user+sys) parity $cp s, winding $cw s; peak RSS parity $((${rp%.*} / 1024)) MB, winding $((${rw%.*} / 1024)) MB"
    done
done
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
