#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# One clvox batch shard per Slurm array task (docs/cli.md "Batch runs"):
#   sbatch [--array=0-63] scripts/tools/slurm_batch.sh MANIFEST OUTDIR [RESOLUTION [BATCH OPTIONS...]]
# Task k of an array of N tasks (a range A-B, with :step or %limit if wanted)
# runs shard k/N of the manifest: OUTDIR/{n}.exr for mesh n, and its JSON
# lines in OUTDIR/shard-k.jsonl. Re-submitting the same array after a
# time-out or scancel resumes: finished outputs are skipped, and a killed
# run leaves no output behind. CLVOX names the binary (default: clvox on
# PATH). tests/test_slurm.sh runs this under a real single-node Slurm.
#SBATCH --job-name=clvox
#SBATCH --array=0-63
#SBATCH --cpus-per-task=4
#SBATCH --output=clvox-%a.log
set -eu
if [ $# -lt 2 ]; then
  echo "usage: sbatch [--array=0-N] $0 MANIFEST OUTDIR [RESOLUTION [clvox batch options...]]" >&2
  exit 2
fi
if [ -z "${SLURM_ARRAY_TASK_ID:-}" ] || [ -z "${SLURM_ARRAY_TASK_COUNT:-}" ]; then
  echo "slurm_batch.sh: not a job array task: submit it with sbatch --array=0-N" >&2
  exit 2
fi
manifest=$1 out=$2 res=${3:-64}
shift 2
[ $# -gt 0 ] && shift
# the task's rank in the array, whatever its first index and step
i=$(( (SLURM_ARRAY_TASK_ID - ${SLURM_ARRAY_TASK_MIN:-0}) / ${SLURM_ARRAY_TASK_STEP:-1} ))
n=$SLURM_ARRAY_TASK_COUNT
if [ "$i" -lt 0 ] || [ "$i" -ge "$n" ]; then
  echo "slurm_batch.sh: task $SLURM_ARRAY_TASK_ID is not in a range array of $n tasks (use --array=A-B[:S])" >&2
  exit 2
fi
mkdir -p "$out"
exec "${CLVOX:-clvox}" batch --manifest "$manifest" -r "$res" -o "$out/{n}.exr" --skip-existing \
    --shard "$i/$n" --json "$@" > "$out/shard-$i.jsonl"
