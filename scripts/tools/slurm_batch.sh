#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# One clvox batch shard per Slurm array task (README "Batch runs").
#   sbatch scripts/tools/slurm_batch.sh MANIFEST OUTDIR [RESOLUTION]
# Re-submitting after a time-out resumes: finished outputs are skipped.
#SBATCH --job-name=clvox
#SBATCH --array=0-63
#SBATCH --cpus-per-task=4
#SBATCH --output=clvox-%a.log
set -eu
exec clvox batch --manifest "$1" -r "${3:-64}" -o "$2/{n}.exr" --skip-existing \
    --shard "$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT" --json > "$2/shard-$SLURM_ARRAY_TASK_ID.jsonl"
