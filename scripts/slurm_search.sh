#!/usr/bin/env bash
# A search spread over a cluster: each task of a Slurm job array runs every N-th trial and logs it
# to the shared folder; a last job, started when the array is done, picks the winner from every
# shard's log and trains the final models. Any runner that sets a task index works the same way.
#
#   sbatch --array=0-7 scripts/slurm_search.sh data/my_dataset runs/my_search
#   sbatch --dependency=afterok:<the array's job id> --wrap \
#     "braille train --data data/my_dataset --collect runs/my_search --seeds 3 --out runs/my_search/model.safetensors"
#
#SBATCH --job-name=braille-search
#SBATCH --cpus-per-task=1
#SBATCH --mem=2G
#SBATCH --time=04:00:00
set -euo pipefail
data=${1:?a dataset folder}
dir=${2:?a shared folder for the trial logs}
n=${SLURM_ARRAY_TASK_COUNT:?run as a job array (sbatch --array=0-N)}
i=${SLURM_ARRAY_TASK_ID:?run as a job array}
# trials: as many as the array has tasks times the trials each should run
braille train --data "$data" --search --search-trials "${TRIALS:-32}" --shard "$i/$n" \
  --search-dir "$dir" --out "$dir/model.safetensors" --quiet
