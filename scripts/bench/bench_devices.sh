#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Several devices at once (issue 34), a benchmark, not a test: whole clvox
# process time and each device's share for
#   elephant-with-holes 256^3 (default winding), bunny00 512^3 --oversample 4,
#   armadillo 2048^3, armadillo subdivided twice (832 k triangles) at 1024^3
# with one PoCL `basic` device (one thread), two `basic` devices, one
# `pthread` device (every core) and `pthread basic`, in one run, the
# device sets interleaved round by round; the best of R runs is shown.
#
#   scripts/bench/bench_devices.sh [--quick] [--repeat R] [--base BIN]
#
#   --quick      the first two cases only
#   --repeat R   runs per case and device set (default 3)
#   --base BIN   also time BIN (an older clvox) on one pthread device, in
#                the same rounds: the single-device path before/after
#
# On a 2-core machine every PoCL device shares the same two cores: two
# `basic` devices can reach 2x one `basic` device, and `pthread basic` at
# best what `pthread` alone does. "eff" is clvox's scheduling efficiency
# (achieved speed-up over the fastest device / the ideal one from the
# devices' measured throughputs); "shares" the devices' shares of the
# slices. Markdown to stdout and to build/bench/devices.md. On a machine
# with a GPU, scripts/gpu_check.sh runs GPU / CPU / both.
[ -z "${BASH_VERSION:-}" ] && exec bash "$0" "$@"
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"

quick=0 repeat=3 base=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --repeat) repeat=${2:?--repeat needs a number}; shift ;;
    --repeat=*) repeat=${1#*=} ;;
    --base) base=${2:?--base needs a program}; shift ;;
    --base=*) base=${1#*=} ;;
    -h|--help) sed -n '3,24p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench_devices.sh: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done
case "$repeat" in ''|*[!0-9]*|0) echo "bench_devices.sh: --repeat needs a positive number" >&2; exit 2 ;; esac

clvox=${CLVOX_BENCH_BIN:-build/release/clvox}
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$here/build/pocl-cache}"
export CLVOX_CACHE_DIR="${CLVOX_CACHE_DIR:-$here/build/clvox-cache}"
mkdir -p "$POCL_CACHE_DIR" build/bench
[ -x "$clvox" ] || make -s CONFIG=release >&2
[ -f data/meshes/armadillo.off ] || sh scripts/fetch_meshes.sh >&2
cases="elephant-with-holes.off:256: bunny00.off:512:--oversample=4"
if [ "$quick" -eq 0 ]; then
  make -s CONFIG=release bench-tools >&2
  [ -f data/meshes/armadillo_s2.ply ] ||
    build/release/bench/subdivide data/meshes/armadillo.off 2 data/meshes/armadillo_s2.ply >&2
  cases="$cases armadillo.off:2048: armadillo_s2.ply:1024:"
fi
# label|POCL_DEVICES|--device
sets=("basic|basic|0" "2basic|basic basic|all" "pthread|pthread|0" "pthread+basic|pthread basic|all")
[ -n "$base" ] && sets+=(base)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# run LABEL POCL_DEVICES DEVICE BIN MESH N OPTS -> "wall eff shares"
run() {
  local json
  json=$(POCL_DEVICES="$2" "$4" "data/meshes/$5" -r "$6" ${7//,/ } --device "$3" -q --json -o "$out/v.exr" 2>/dev/null) ||
    { echo "fail"; return; }
  python3 -c '
import json, sys
d = json.loads(sys.argv[1])
t = d["seconds"]["wall"]
devs = d.get("devices") or []
total = sum(e["slices"] for e in devs) or 1
shares = "/".join("%.0f%%" % (100.0 * e["slices"] / total) for e in devs) if len(devs) > 1 else "-"
eff = d.get("scheduling_efficiency")
print("%.3f %s %s" % (t, "%.2f" % eff if eff is not None else "-", shares))' "$json"
}

declare -A best eff share
for c in $cases; do
  IFS=: read -r mesh n opts <<<"$c"
  for r in $(seq "$repeat"); do
    for s in "${sets[@]}"; do
      if [ "$s" = base ]; then label=base; pd=pthread; dv=0; bin=$base
      else IFS='|' read -r label pd dv <<<"$s"; bin=$clvox; fi
      res=$(run "$label" "$pd" "$dv" "$bin" "$mesh" "$n" "$opts")
      [ "$res" = fail ] && { echo "bench_devices: $label $mesh failed" >&2; continue; }
      read -r t e sh <<<"$res"
      key="$mesh $n $label"
      if [ -z "${best[$key]:-}" ] || python3 -c "import sys; sys.exit(not ($t < ${best[$key]}))"; then
        best[$key]=$t; eff[$key]=$e; share[$key]=$sh
      fi
      echo "bench_devices: $key round $r: $t s (eff $e, shares $sh)" >&2
    done
  done
done

{
  echo "| case | 1 basic | 2 basic | 2 basic vs 1 basic | 1 pthread | 2 basic vs pthread | pthread+basic | pthread+basic vs pthread | eff (2 basic / pthread+basic) | shares (2 basic / pthread+basic) |${base:+ base pthread | now vs base |}"
  echo "|---|---|---|---|---|---|---|---|---|---|${base:+---|---|}"
  for c in $cases; do
    IFS=: read -r mesh n opts <<<"$c"
    k="$mesh $n"
    b1=${best[$k basic]:-nan} b2=${best[$k 2basic]:-nan} p=${best[$k pthread]:-nan} pb=${best[$k pthread+basic]:-nan}
    row=$(python3 -c "
import math, sys
b1, b2, p, pb = (float(x) for x in sys.argv[1:5])
f = lambda x: '%.3f s' % x
r = lambda a, b: '%.2fx' % (a / b) if b > 0 else '-'
print('| %s | %s | %s | %s | %s | %s | %s |' % (f(b1), f(b2), r(b1, b2), f(p), r(p, b2), f(pb), r(p, pb)))
" "$b1" "$b2" "$p" "$pb")
    extra=""
    if [ -n "$base" ]; then
      bb=${best[$k base]:-nan}
      extra=$(python3 -c "import sys; b, p = float(sys.argv[1]), float(sys.argv[2]); print(' %.3f s | %.2fx |' % (b, b / p))" "$bb" "$p")
    fi
    echo "| $mesh ${n}^3 ${opts//,/ } $row ${eff[$k 2basic]:--} / ${eff[$k pthread+basic]:--} | ${share[$k 2basic]:--} / ${share[$k pthread+basic]:--} |$extra"
  done
} | tee build/bench/devices.md
