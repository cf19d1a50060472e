#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Surface and conservative voxelization benchmark (issue 11), not a test:
# --mode surface and --mode conservative against the solid run of the same
# mesh and grid, and trimesh's surface voxelization (the peer users pick) in
# the same run.
#
#   scripts/bench/bench_surface.sh [--quick] [--repeat R] [--no-trimesh] [--base BIN]
#
#   --quick       armadillo only, N = 256 and 512
#   --repeat R    runs per case, the best process time is shown (default 3)
#   --no-trimesh  skip trimesh (it needs build/venv-trimesh: python3 -m venv
#                 build/venv-trimesh && build/venv-trimesh/bin/pip install
#                 trimesh scipy)
#   --base BIN    also time BIN (e.g. a build of main) in solid mode on every
#                 case, interleaved with this build's runs: the solid path
#                 before and after
#
# Cases: armadillo.off (52 k triangles), bunny00.off (75 k) and armadillo
# subdivided twice (832 k, binary PLY from scripts/bench/subdivide.c) at N = 256,
# 512, 1024 (-r N), ray method, modes solid / surface / conservative. Whole
# clvox process (load, OpenCL set-up with a warm PoCL kernel cache, the
# method, EXR write with the default RLE), wall seconds, best of R; "raster"
# is the classify stage of clvox's summary (the surface kernel's device time
# in surface mode; parity + surface in conservative mode). trimesh:
# Trimesh.voxelized(pitch) at pitch = longest side / N (voxelize_subdivide)
# and .fill(), best of R (at N = 256 only; Python, one thread), with a voxel
# by voxel comparison against clvox on the same grid
# (scripts/bench/bench_surface_trimesh.py). Markdown to stdout and to
# build/bench/surface.md.
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"

quick=0 repeat=3 use_trimesh=1 base=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --repeat) repeat=${2:?--repeat needs a number}; shift ;;
    --repeat=*) repeat=${1#*=} ;;
    --no-trimesh) use_trimesh=0 ;;
    --base) base=${2:?--base needs a clvox binary}; shift ;;
    --base=*) base=${1#*=} ;;
    -h|--help) sed -n '2,31p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench_surface.sh: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done
case "$repeat" in ''|*[!0-9]*|0) echo "bench_surface.sh: --repeat needs a positive number" >&2; exit 2 ;; esac

clvox=${CLVOX_BENCH_BIN:-build/release/clvox}
outdir=build/bench tools=build/release/bench py=build/venv-trimesh/bin/python
mkdir -p "$outdir" "$tools"
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
mkdir -p "$POCL_CACHE_DIR"
log() { echo "bench_surface: $*" >&2; }
[ -x "$clvox" ] || make -s CONFIG=release >&2
[ -f data/meshes/bunny00.off ] || sh scripts/fetch_meshes.sh >&2
if [ "$use_trimesh" -eq 1 ] && ! "$py" -c 'import trimesh, scipy' 2>/dev/null; then
  log "trimesh not installed in build/venv-trimesh: skipped (see --help)"; use_trimesh=0
fi
make -s CONFIG=release bench-tools >&2   # volume_raw, subdivide

meshes="armadillo.off bunny00.off armadillo_s2.ply" sizes="256 512 1024"
if [ "$quick" -eq 1 ]; then
  meshes="armadillo.off" sizes="256 512"
else
  [ -f data/meshes/armadillo_s2.ply ] || "$tools/subdivide" data/meshes/armadillo.off 2 data/meshes/armadillo_s2.ply >&2
fi
modes="solid surface conservative"

tmp=$(mktemp -d "$outdir/surf.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
"$clvox" -r 32 --mode conservative -o "$tmp/warm.exr" -q data/meshes/bunny00.off # warm the kernel cache
[ -z "$base" ] || "$base" -r 32 -o "$tmp/warm.exr" -q data/meshes/bunny00.off

# One run; prints: process raster filled
run_one() {
  local bin=$1 mesh=$2 n=$3 mode=$4 t0 t1 opt=""
  [ "$mode" = solid ] && [ "$bin" != "$clvox" ] || opt="--mode $mode"
  rm -f "$tmp/out.exr"
  t0=$EPOCHREALTIME
  # shellcheck disable=SC2086
  "$bin" "data/meshes/$mesh" -r "$n" $opt -o "$tmp/out.exr" --no-progress >"$tmp/stdout.txt" 2>"$tmp/stderr.txt" ||
    { log "FAILED: $bin $mesh -r $n $opt"; tail -n 3 "$tmp/stderr.txt" >&2; return 1; }
  t1=$EPOCHREALTIME
  awk -v t0="$t0" -v t1="$t1" '
    function grab(name,   i) { for (i = 1; i < NF; i++) if ($i == name) return $(i+1); return "-" }
    /^time[ \t]/ { k = grab("classify") }
    /^filled[ \t]/ { f = $2 }
    END { printf "%.3f\t%s\t%s\n", t1 - t0, k, f }' "$tmp/stdout.txt"
}

results="$outdir/surface.tsv" peers="$outdir/surface_trimesh.jsonl"
: >"$results"; : >"$peers"
for mesh in $meshes; do
  for n in $sizes; do
    labels="$modes"; [ -z "$base" ] || labels="$labels base"
    declare -A best=()
    for _ in $(seq "$repeat"); do # interleaved, so that load on the machine hits every mode alike
      for label in $labels; do
        if [ "$label" = base ]; then rec=$(run_one "$base" "$mesh" "$n" solid) || continue
        else rec=$(run_one "$clvox" "$mesh" "$n" "$label") || continue; fi
        if [ -z "${best[$label]:-}" ] || awk -v a="${rec%%$'\t'*}" -v b="${best[$label]%%$'\t'*}" 'BEGIN { exit !(a < b) }'; then
          best[$label]=$rec
        fi
      done
    done
    for label in $labels; do
      [ -n "${best[$label]:-}" ] || continue
      printf '%s\t%s\t%s\t%s\n' "$mesh" "$n" "$label" "${best[$label]}" >>"$results"
      log "$(printf '%-17s N=%-4s %-12s %ss' "$mesh" "$n" "$label" "${best[$label]%%$'\t'*}")"
    done
    unset best
    if [ "$use_trimesh" -eq 1 ] && [ "$n" = 256 ] && [ "$mesh" != armadillo_s2.ply ]; then
      log "trimesh $mesh N=$n"
      "$py" scripts/bench/bench_surface_trimesh.py "data/meshes/$mesh" "$n" "$clvox" "$tools/volume_raw" "$tmp" "$repeat" >>"$peers" ||
        log "trimesh FAILED on $mesh"
    fi
  done
done

{
  echo "# clvox surface benchmark ($(date -u +%Y-%m-%d), $(nproc) cores, best of $repeat, PoCL kernel cache warm)"
  echo
  echo "Whole clvox process, seconds (ratio to the solid run of the same mesh and N); filled voxels:"
  echo
  echo "| mesh | N | solid | surface | conservative |$([ -z "$base" ] || echo ' solid, base build |')"
  echo "|---|---|---|---|---|$([ -z "$base" ] || echo '---|')"
  awk -F '\t' -v base="$base" '
    { k = $1 SUBSEP $2; if (!(k in seen)) { seen[k] = 1; order[++n] = k } t[k, $3] = $4; f[k, $3] = $6 }
    END {
      for (i = 1; i <= n; i++) { k = order[i]; split(k, p, SUBSEP); s = t[k, "solid"]
        printf "| %s | %s | %.2f (%s) |", p[1], p[2], s, f[k, "solid"]
        split("surface conservative", m, " ")
        for (j = 1; j <= 2; j++) printf " %.2f (%.2fx; %s) |", t[k, m[j]], t[k, m[j]] / s, f[k, m[j]]
        if (base != "") printf " %.2f (%.2fx) |", t[k, "base"], t[k, "base"] / s
        print "" } }' "$results"
  echo
  echo "Surface kernel device seconds (classify stage; conservative: parity + surface):"
  echo
  echo "| mesh | N | solid | surface | conservative |"
  echo "|---|---|---|---|---|"
  awk -F '\t' '{ k = $1 SUBSEP $2; if (!(k in seen)) { seen[k] = 1; order[++n] = k } r[k, $3] = $5 }
    END { for (i = 1; i <= n; i++) { k = order[i]; split(k, p, SUBSEP)
      printf "| %s | %s | %s | %s | %s |\n", p[1], p[2], r[k, "solid"], r[k, "surface"], r[k, "conservative"] } }' "$results"
  if [ -s "$peers" ]; then
    echo
    echo "trimesh $("$py" -c 'import trimesh; print(trimesh.__version__)') on the same grids (voxelized = surface, .fill() after it; seconds of the call alone, best of $repeat), and voxel-by-voxel against clvox:"
    echo
    echo "| mesh | N | trimesh voxelized | trimesh fill | clvox surface (process) | speed-up | trimesh surface | clvox surface | trimesh not in clvox | clvox not in trimesh | trimesh filled | clvox conservative | filled not in conservative | conservative not in filled |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    "$py" - "$peers" "$results" <<'PY'
import json, sys
times = {}
for line in open(sys.argv[2]):
    m, n, label, proc, *_ = line.rstrip("\n").split("\t")
    times[(m, n, label)] = float(proc)
for line in open(sys.argv[1]):
    r = json.loads(line)
    m = r["mesh"].split("/")[-1]; n = str(r["n"])
    cl = times.get((m, n, "surface"))
    sp = f"{r['trimesh_surface_s'] / cl:.0f}x" if cl else "-"
    print(f"| {m} | {n} | {r['trimesh_surface_s']:.2f} | {r['trimesh_fill_s']:.2f} | {cl if cl else '-'} | {sp} | "
          f"{r['trimesh_surface']} | {r['clvox_surface']} | {r['trimesh_surface_not_clvox']} | {r['clvox_surface_not_trimesh']} | "
          f"{r['trimesh_filled']} | {r['clvox_conservative']} | {r['trimesh_filled_not_clvox_conservative']} | "
          f"{r['clvox_conservative_not_trimesh_filled']} |")
PY
  fi
} | tee "$outdir/surface.md"
