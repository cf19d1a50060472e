#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Winding-number inside test, accuracy and cost (not a test; issue 9):
# for the winding corpus (tests/meshgen.c tmesh_winding_corpus: open,
# cracked, mis-oriented, overlapping, non-manifold meshes) and real open
# meshes from data/meshes, the IoU against the exact generalized winding
# number oracle of
#   clvox --inside winding, --inside winding-abs, --inside parity, --method tetra,
#   trimesh's contains (ray parity) and voxelized().fill() (when trimesh,
#   rtree and scipy import in build/venv-formats or python3; on 20000
#   sampled centres),
# plus the whole-process wall time of clvox winding vs parity (best of R).
#
#   scripts/bench/bench_winding.sh [-r N] [--repeat R] [--quick] [--no-trimesh]
#
#   -r N         grid resolution (default 128). The oracle is brute force over
#                the boundary (build/release/bench/bench_winding_oracle: exact crossings
#                plus boundary-strip solid angles, O(columns x triangles +
#                voxels x boundary edges)); meshes with more than 1000 boundary
#                edges run at N/2 (their lines say so)
#   --repeat R   clvox runs per case for the times (default 3)
#   --quick      corpus only, no real meshes, no trimesh
# Each clvox run is stopped after CLVOX_BENCH_TIMEOUT seconds (default 120;
# the cell then says "timeout").
#
# Oracle orientation: corpus meshes are compared with the orientation repair
# should arrive at (the generator's "truth"; the Moebius strip has none and
# shows "-"); real meshes with each connected component oriented so that its
# total winding is positive (outwards). Until clvox has --inside, the winding
# columns say "n/a" and only parity and tetra are measured.
# Writes a markdown table to stdout and build/bench/winding.md.
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"

res=128 repeat=3 quick=0 use_trimesh=1 limit=${CLVOX_BENCH_TIMEOUT:-120}
while [ $# -gt 0 ]; do
  case "$1" in
    -r) res=${2:?-r needs a number}; shift ;;
    --repeat) repeat=${2:?--repeat needs a number}; shift ;;
    --quick) quick=1 use_trimesh=0 ;;
    --no-trimesh) use_trimesh=0 ;;
    -h|--help) sed -n '2,32p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench_winding.sh: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done

clvox=${CLVOX_BENCH_BIN:-build/release/clvox}
outdir=build/bench tools=build/release/bench   # make bench-tools
mkdir -p "$outdir" "$tools"
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
mkdir -p "$POCL_CACHE_DIR"
log() { echo "bench_winding: $*" >&2; }
[ -x "$clvox" ] || make -s CONFIG=release >&2
oracle=$tools/bench_winding_oracle
make -s CONFIG=release bench-tools >&2   # the oracle: -ffp-contract=off, as the library
py=python3
[ -x build/venv-formats/bin/python ] && py=build/venv-formats/bin/python
"$py" -c 'import numpy' 2>/dev/null || { log "numpy is needed ($py)"; exit 1; }
if [ "$use_trimesh" -eq 1 ] && ! "$py" -c 'import trimesh, rtree, scipy' 2>/dev/null; then
  log "trimesh, rtree or scipy missing for $py: trimesh columns skipped"; use_trimesh=0
fi
tmp=$(mktemp -d "$outdir/winding.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
have_inside=0 # does this clvox take --inside? (tried, not read from --help)
"$clvox" tests/data/default.obj -r 8 --inside parity -o "$tmp/probe.npy" -q --no-progress 2>/dev/null && have_inside=1
[ "$have_inside" -eq 1 ] || log "clvox has no --inside yet: winding columns n/a, parity is clvox's default"
"$oracle" corpus "$tmp" >"$tmp/corpus.txt"
cases=()
while read -r name file truth; do cases+=("$name|$file|$truth"); done <"$tmp/corpus.txt"
if [ "$quick" -eq 0 ]; then
  [ -f data/meshes/mushroom.off ] || sh scripts/fetch_meshes.sh >&2
  for m in elephant-with-holes mech-holes-shark mushroom head pig nefertiti mask_cone blob corner_with_hole cube-ouvert lion; do
    [ -f "data/meshes/$m.off" ] && cases+=("$m|data/meshes/$m.off|auto")
  done
fi
"$clvox" -r 16 -o "$tmp/warm.npy" -q --no-progress tests/data/default.obj || true # warm the kernel cache

# best wall time of R runs of: clvox FILE -r N ARGS... -o OUT.npy (one run when
# it takes over 5 s; "timeout" past $limit s, and OUT.npy is then removed)
best_time() {
  local out=$1 file=$2 n=$3 best="" t0 t1 dt rc; shift 3
  for _ in $(seq "$repeat"); do
    rm -f "$out"
    t0=$EPOCHREALTIME
    rc=0
    timeout -k 5 "$limit" "$clvox" "$file" -r "$n" "$@" -o "$out" -q --no-progress 2>"$tmp/err.txt" || rc=$?
    t1=$EPOCHREALTIME
    if [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; then rm -f "$out"; echo "timeout"; return; fi
    if [ "$rc" -ne 0 ]; then tail -n 2 "$tmp/err.txt" >&2; rm -f "$out"; echo fail; return; fi
    dt=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }')
    if [ -z "$best" ] || awk -v a="$dt" -v b="$best" 'BEGIN { exit !(a < b) }'; then best=$dt; fi
    awk -v a="$dt" 'BEGIN { exit !(a > 5) }' && break
  done
  echo "$best"
}

report=$outdir/winding.md
{
  echo "# clvox winding vs parity, IoU against the exact winding number (N = $res)"
  echo
  echo "| mesh | N | boundary edges | oracle inside | near 1/2 | winding | winding-abs | parity | tetra | trimesh contains | trimesh fill | winding s | parity s |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
} >"$report.tmp"
for c in "${cases[@]}"; do
  IFS='|' read -r name file truth <<<"$c"
  n=$res
  if [ "$name" = elephant-with-holes ]; then n=$((res / 2)); fi # 1353 boundary edges
  orc="-" edges="-" inside="-" near="-"
  if [ "$truth" != none ]; then
    targ=(); [ "$truth" = "-" ] || targ=("$truth")
    line=$("$oracle" oracle "$file" "$n" "$tmp/oracle.npy" "${targ[@]}")
    edges=$(awk '{print $6}' <<<"$line"); near=$(awk '{print $8}' <<<"$line"); inside=$(awk '{print $10}' <<<"$line")
    orc=$tmp/oracle.npy
  fi
  tw="n/a" tp="-"; vols=()
  if [ "$have_inside" -eq 1 ]; then
    tw=$(best_time "$tmp/winding.npy" "$file" "$n" --inside winding)
    best_time "$tmp/abs.npy" "$file" "$n" --inside winding-abs >/dev/null
    tp=$(best_time "$tmp/parity.npy" "$file" "$n" --inside parity)
    [ -f "$tmp/winding.npy" ] && vols+=("winding=$tmp/winding.npy")
    [ -f "$tmp/abs.npy" ] && vols+=("winding-abs=$tmp/abs.npy")
  else
    tp=$(best_time "$tmp/parity.npy" "$file" "$n")
  fi
  timeout -k 5 "$limit" "$clvox" "$file" -r "$n" --method tetra -o "$tmp/tetra.npy" -q --no-progress 2>/dev/null ||
    rm -f "$tmp/tetra.npy"
  vols+=("parity=$tmp/parity.npy")
  [ -f "$tmp/tetra.npy" ] && vols+=("tetra=$tmp/tetra.npy")
  declare -A j=([winding]="n/a" [winding-abs]="n/a" [parity]="-" [tetra]="-" [trimesh-contains]="-" [trimesh-fill]="-")
  [ "$have_inside" -eq 0 ] || [ -f "$tmp/winding.npy" ] || j[winding]=$tw
  [ "$have_inside" -eq 0 ] || [ -f "$tmp/abs.npy" ] || j[winding-abs]="-"
  if [ "$orc" != "-" ]; then
    targs=()
    if [ "$use_trimesh" -eq 1 ]; then
      tm=$file; [ "$truth" = "-" ] || [ "$truth" = auto ] || tm=$truth # trimesh gets the repaired mesh: its best case
      targs=(--json "$tmp/parity.json" --trimesh "$tm")
    fi
    while IFS=$'\t' read -r k v _ _ extra; do
      j[$k]=$v; [ -z "${extra:-}" ] || j[$k]="$v (${extra%% on*})"
    done < <("$py" scripts/bench/bench_winding_iou.py "$orc" "${targs[@]}" "${vols[@]}")
  fi
  printf '| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n' "$name" "$n" "$edges" "$inside" "$near" \
    "${j[winding]}" "${j[winding-abs]}" "${j[parity]}" "${j[tetra]}" "${j[trimesh-contains]}" "${j[trimesh-fill]}" \
    "$tw" "$tp" >>"$report.tmp"
  log "$(tail -n 1 "$report.tmp")"
  unset j
done
mv "$report.tmp" "$report"
cat "$report"
