#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Grey-level (coverage) benchmark, not a test: the paper's Table 1 (Thon et
# al.: Athena, 91 k faces, 512^3: 5.3 s binary, 30 s 2x2x2, 88 s 3x3x3, 169 s
# 4x4x4) for clvox on this machine.
#
#   scripts/bench/bench_coverage.sh [--quick] [--repeat R]
#
#   --quick      bunny00 only, N = 128 and 512
#   --repeat R   runs per case, the best process time is shown (default 3)
#
# Cases: bunny00.off (75 k triangles) and armadillo subdivided twice (832 k,
# binary PLY made by scripts/bench/subdivide.c) at N = 64, 128, 256, 512 x binary,
# K = 1..4 uniform and K = 2..4 stochastic (--oversample K: K x K rays per
# column, K points per voxel). Whole clvox process (load, OpenCL set-up with
# a warm PoCL kernel cache, partition, cast, coverage counting, EXR write with
# the default RLE), wall seconds; the stage seconds are clvox's summary
# ("classify" is the consumer kernel: parity, or coverage counting); "vol err"
# is the estimated volume (sum of coverage x voxel volume; filled voxels when
# binary) against the mesh's enclosed volume. Markdown to stdout and to
# build/bench/coverage.md.
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"

quick=0 repeat=3
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --repeat) repeat=${2:?--repeat needs a number}; shift ;;
    --repeat=*) repeat=${1#*=} ;;
    -h|--help) sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench_coverage.sh: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done
case "$repeat" in ''|*[!0-9]*|0) echo "bench_coverage.sh: --repeat needs a positive number" >&2; exit 2 ;; esac

clvox=${CLVOX_BENCH_BIN:-build/release/clvox}
outdir=build/bench tools=build/release/bench   # make bench-tools
mkdir -p "$outdir" "$tools"
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
mkdir -p "$POCL_CACHE_DIR"
log() { echo "bench_coverage: $*" >&2; }
[ -x "$clvox" ] || make -s CONFIG=release >&2
[ -f data/meshes/bunny00.off ] || sh scripts/fetch_meshes.sh >&2

meshes="bunny00.off"
sizes="64 128 256 512"
if [ "$quick" -eq 1 ]; then
  sizes="128 512"
else
  make -s CONFIG=release bench-tools >&2
  [ -f data/meshes/armadillo_s2.ply ] || "$tools/subdivide" data/meshes/armadillo.off 2 data/meshes/armadillo_s2.ply >&2
  meshes="bunny00.off armadillo_s2.ply"
fi
# label:options (":" alone = binary)
modes="binary: K1:--oversample=1 K2:--oversample=2 K3:--oversample=3 K4:--oversample=4
       K2s:--oversample=2,--stochastic K3s:--oversample=3,--stochastic K4s:--oversample=4,--stochastic"

tmp=$(mktemp -d "$outdir/cov.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
"$clvox" -r 32 --oversample 2 -o "$tmp/warm.exr" -q data/meshes/bunny00.off # warm the kernel cache

# One run; prints: process partition cast classify write vol_err_percent out_mb
run_one() {
  local mesh=$1 n=$2 opts=$3 t0 t1
  rm -f "$tmp/out.exr"
  t0=$EPOCHREALTIME
  # shellcheck disable=SC2086
  "$clvox" "data/meshes/$mesh" -r "$n" ${opts//,/ } -o "$tmp/out.exr" --no-progress >"$tmp/stdout.txt" 2>"$tmp/stderr.txt" ||
    { log "FAILED: $clvox $mesh -r $n $opts"; tail -n 3 "$tmp/stderr.txt" >&2; return 1; }
  t1=$EPOCHREALTIME
  local bytes; bytes=$(stat -c %s "$tmp/out.exr")
  awk -v t0="$t0" -v t1="$t1" -v bytes="$bytes" '
    function grab(name,   i) { for (i = 1; i < NF; i++) if ($i == name) return $(i+1); return "-" }
    /^time[ \t]/ { p = grab("partition"); c = grab("cast"); k = grab("classify"); w = grab("write") }
    /^volume[ \t]/ { v = grab("vs"); if (v != "-" && v + 0 != 0) e = sprintf("%+.4f", 100 * ($2 - v) / v) }
    END { printf "%.3f\t%s\t%s\t%s\t%s\t%s\t%.1f\n", t1 - t0, p, c, k, w, e, bytes / 1e6 }' "$tmp/stdout.txt"
}

results="$outdir/coverage.tsv"
: >"$results"
for mesh in $meshes; do
  for n in $sizes; do
    for mode in $modes; do
      label=${mode%%:*} opts=${mode#*:}
      best=""
      for _ in $(seq "$repeat"); do
        rec=$(run_one "$mesh" "$n" "$opts") || { best=""; break; }
        if [ -z "$best" ] || awk -v a="${rec%%$'\t'*}" -v b="${best%%$'\t'*}" 'BEGIN { exit !(a < b) }'; then best=$rec; fi
      done
      [ -n "$best" ] || continue
      printf '%s\t%s\t%s\t%s\n' "$mesh" "$n" "$label" "$best" >>"$results"
      log "$(printf '%-17s N=%-4s %-6s %ss' "$mesh" "$n" "$label" "${best%%$'\t'*}")"
    done
  done
done

{
  echo "# clvox coverage benchmark ($(date -u +%Y-%m-%d), $(nproc) cores, best of $repeat, PoCL kernel cache warm)"
  echo
  echo "Whole process, seconds (ratio to the binary run of the same mesh and N in this run):"
  echo
  for mesh in $meshes; do
    echo "### $mesh"
    echo
    printf '| N |'; for mode in $modes; do printf ' %s |' "${mode%%:*}"; done; echo
    printf '|---|'; for _ in $modes; do printf -- '---|'; done; echo
    for n in $sizes; do
      awk -F '\t' -v mesh="$mesh" -v n="$n" -v modes="$modes" '
        $1 == mesh && $2 == n { t[$3] = $4 }
        END {
          split(modes, m, /[ \n\t]+/); printf "| %s |", n
          for (i = 1; i in m; i++) { l = m[i]; sub(/:.*/, "", l); if (l == "") continue
            if (!(l in t)) { printf " - |"; continue }
            if (l == "binary" || !("binary" in t)) printf " %.2f |", t[l]
            else printf " %.2f (%.1fx) |", t[l], t[l] / t["binary"] }
          print "" }' "$results"
    done
    echo
    echo "Stages at N = ${sizes##* } (seconds: partition, cast = lookup + intersect + sort, consumer, write; volume error; file MB):"
    echo
    echo "| mode | process | partition | cast | consumer | write | vol err % | MB |"
    echo "|---|---|---|---|---|---|---|---|"
    awk -F '\t' -v mesh="$mesh" -v n="${sizes##* }" '$1 == mesh && $2 == n {
      printf "| %s | %s | %s | %s | %s | %s | %s | %s |\n", $3, $4, $5, $6, $7, $8, $9, $10 }' "$results"
    echo
  done
} | tee "$outdir/coverage.md"
