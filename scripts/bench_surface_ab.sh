#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Before/after benchmark of the surface raster (issue 11), not a test: a
# base clvox binary (e.g. main's build) against this build, interleaved
# round by round so that load on the shared machine hits both alike.
#
#   scripts/bench_surface_ab.sh --base BIN [--rounds R] [--mesh FILE] [-r N] [--modes "solid conservative surface"]
#
# Each round runs, for every mode, the base binary then this build (the
# order of the two swapped every other round) on FILE at -r N with
# --no-progress -o <tmp>.exr; it records the whole process's wall seconds
# (bash EPOCHREALTIME around the process, PoCL kernel cache warm), its CPU
# seconds (user + system, /usr/bin/time: less disturbed by other load than
# wall time on a shared machine) and the classify stage of clvox's summary (surface mode: the raster's device time;
# conservative: parity + raster), and checks that both binaries wrote
# byte-identical EXRs (a difference fails the script). Prints medians over
# the rounds, the ratio conservative / solid of the medians and the median
# of the per-round ratios, and `uptime` before and after.
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"

base="" rounds=7 mesh=data/meshes/armadillo.off n=512 modes="solid conservative surface"
while [ $# -gt 0 ]; do
  case "$1" in
    --base) base=${2:?--base needs a clvox binary}; shift ;;
    --rounds) rounds=${2:?--rounds needs a number}; shift ;;
    --mesh) mesh=${2:?--mesh needs a file}; shift ;;
    -r) n=${2:?-r needs a number}; shift ;;
    --modes) modes=${2:?--modes needs a list}; shift ;;
    -h|--help) sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench_surface_ab.sh: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done
[ -n "$base" ] || { echo "bench_surface_ab.sh: --base BIN is required" >&2; exit 2; }
case "$rounds" in ''|*[!0-9]*|0) echo "bench_surface_ab.sh: --rounds needs a positive number" >&2; exit 2 ;; esac
new=${CLVOX_BENCH_BIN:-build/release/clvox}
[ -x "$new" ] || make -s CONFIG=release >&2
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
mkdir -p "$POCL_CACHE_DIR" build/bench
tmp=$(mktemp -d build/bench/ab.XXXXXX)
trap 'rm -rf "$tmp"' EXIT

echo "load before: $(uptime)"
for bin in "$base" "$new"; do # warm the kernel cache of both
  for mode in $modes; do "$bin" "$mesh" -r 32 --mode "$mode" -q -o "$tmp/warm.exr"; done
done

# run BIN MODE OUT: prints "wall classify cpu"
run() {
  local t0 t1
  t0=$EPOCHREALTIME
  /usr/bin/time -f '%U %S' -o "$tmp/cpu.txt" "$1" "$mesh" -r "$n" --mode "$2" --no-progress -o "$3" \
    >"$tmp/stdout.txt" 2>"$tmp/stderr.txt" ||
    { echo "FAILED: $1 $mesh -r $n --mode $2" >&2; cat "$tmp/stderr.txt" >&2; exit 1; }
  t1=$EPOCHREALTIME
  awk -v t0="$t0" -v t1="$t1" -v cpu="$(cat "$tmp/cpu.txt")" '
    /^time[ \t]/ { for (i = 1; i < NF; i++) if ($i == "classify") k = $(i + 1) }
    END { split(cpu, c, " "); printf "%.4f %s %.2f\n", t1 - t0, k, c[1] + c[2] }' "$tmp/stdout.txt"
}

: >"$tmp/rec"
for r in $(seq "$rounds"); do
  for mode in $modes; do
    if [ $((r % 2)) -eq 1 ]; then order="base new"; else order="new base"; fi
    for who in $order; do
      if [ "$who" = base ]; then bin=$base; else bin=$new; fi
      echo "$r $mode $who $(run "$bin" "$mode" "$tmp/$who.exr")" >>"$tmp/rec"
    done
    cmp -s "$tmp/base.exr" "$tmp/new.exr" || { echo "DIFFERENT OUTPUT: $mode, round $r" >&2; exit 1; }
  done
done
echo "load after: $(uptime)"
echo "$mesh -r $n, $rounds interleaved rounds, medians; outputs byte-identical in every run"
awk -v modes="$modes" '
  function median(key,   m, i, j, t, a) {
    m = cnt[key]; for (i = 1; i <= m; i++) a[i] = val[key, i]
    for (i = 2; i <= m; i++) { t = a[i]; for (j = i - 1; j >= 1 && a[j] > t; j--) a[j + 1] = a[j]; a[j + 1] = t }
    return m % 2 ? a[(m + 1) / 2] : (a[m / 2] + a[m / 2 + 1]) / 2 }
  { k = $3 SUBSEP $2; val[k, ++cnt[k]] = $4; kk = $3 SUBSEP $2 SUBSEP "c"; val[kk, ++cnt[kk]] = $5
    ku = $3 SUBSEP $2 SUBSEP "u"; val[ku, ++cnt[ku]] = $6
    w[$1, $2, $3] = $4; if ($1 > R) R = $1 }
  END {
    nm = split(modes, md, " ")
    printf "| build |"; for (i = 1; i <= nm; i++) printf " %s wall | %s CPU | %s classify |", md[i], md[i], md[i]
    print " conservative / solid, wall (per-round median) | conservative / solid, CPU |"
    printf "|---|"; for (i = 1; i <= nm; i++) printf "---|---|---|"; print "---|---|"
    split("base new", who, " ")
    for (b = 1; b <= 2; b++) {
      printf "| %s |", who[b]
      for (i = 1; i <= nm; i++)
        printf " %.3f | %.2f | %.3f |", median(who[b] SUBSEP md[i]), median(who[b] SUBSEP md[i] SUBSEP "u"),
          median(who[b] SUBSEP md[i] SUBSEP "c")
      if (cnt[who[b] SUBSEP "solid"] && cnt[who[b] SUBSEP "conservative"]) {
        for (r = 1; r <= R; r++) val["ratio" who[b], r] = w[r, "conservative", who[b]] / w[r, "solid", who[b]]
        cnt["ratio" who[b]] = R
        printf " %.3f (%.3f) | %.3f |\n", median(who[b] SUBSEP "conservative") / median(who[b] SUBSEP "solid"),
          median("ratio" who[b]), median(who[b] SUBSEP "conservative" SUBSEP "u") / median(who[b] SUBSEP "solid" SUBSEP "u")
      } else print " - | - |"
    } }' "$tmp/rec"
