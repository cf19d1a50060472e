#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Launch groups (docs/design.md "Several devices"): one case, whole process,
# interleaved: the old binary, this one with its default group size, and
# CLVOX_LAUNCH_SLABS=4 and =16; prints "variant seconds peak-RSS-KB" per run,
# then whether each file equals the old binary's byte for byte.
#   scripts/bench/bench_launch.sh OLD_CLVOX REPEATS MESH ARGS...
#   e.g. scripts/bench/bench_launch.sh /tmp/old/clvox 5 data/meshes/armadillo.off -r 1024
set -u
[ $# -ge 3 ] || { echo "usage: $0 OLD_CLVOX REPEATS MESH [ARGS...]" >&2; exit 2; }
old=$1 reps=$2
shift 2
here=$(cd "$(dirname "$0")/../.." && pwd)
new=${CLVOX_BIN:-$here/build/release/clvox}
out=$(mktemp -d /dev/shm/clvox-launch.XXXXXX 2>/dev/null || mktemp -d)
trap 'rm -rf "$out"' EXIT
for _ in $(seq "$reps"); do
  for v in old default g4 g16; do
    b=$new e=CLVOX_LAUNCH_SLABS=
    case $v in old) b=$old ;; g4) e=CLVOX_LAUNCH_SLABS=4 ;; g16) e=CLVOX_LAUNCH_SLABS=16 ;; esac
    t=$({ /usr/bin/time -f "%e %M" env "$e" "$b" "$@" -q --no-progress -o "$out/$v.exr"; } 2>&1 | tail -n 1)
    echo "$v $t"
  done
done
for v in default g4 g16; do
  if cmp -s "$out/old.exr" "$out/$v.exr"; then echo "$v: same file"; else echo "$v: DIFFERENT file"; fi
done
