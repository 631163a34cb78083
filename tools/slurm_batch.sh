#!/usr/bin/env bash
# Example: `mcvo batch` spread over machines with a Slurm job array, then one
# job that gathers the summary of every run (docs/batch-and-regress.md).
#
#   tools/slurm_batch.sh MANIFEST OUT [SHARDS]      # e.g. tools/slurm_batch.sh runs.json runs 8
#
# Run on the login node, the script submits itself twice:
#   1. an array of SHARDS tasks; task K runs
#        mcvo batch --manifest MANIFEST --out OUT --shard K/SHARDS
#      (K = $SLURM_ARRAY_TASK_ID, 0-based: run i of the manifest goes to task i % SHARDS);
#   2. a job that starts when the whole array has ended (afterany: also when
#      some task failed) and runs
#        mcvo batch --manifest MANIFEST --out OUT --summary-only
#      which writes OUT/summary.csv and OUT/summary.md from the run folders and
#      the status each task recorded; it exits 4 when a run failed or is missing.
# OUT must be on a file system that every node sees. Each run writes only its
# own folder OUT/<name>/ (renamed into place when complete) and its record
# OUT/.batch/runs/<name>.json, so the tasks never write the same file.
# Resubmitting the same command resumes: finished runs that are up to date
# are skipped, so only failed or changed runs are run again.
#
# Environment: MCVO (the executable, default build/mcvo), MCVO_JOBS (runs at
# once per task, default 1). Each run uses the threads of its manifest entry
# or config; when neither says, the CPUs Slurm gave the task divided by
# MCVO_JOBS. Adjust the #SBATCH lines to your cluster.
#
#SBATCH --job-name=mcvo-batch
#SBATCH --cpus-per-task=4
#SBATCH --mem=16G
#SBATCH --time=24:00:00
#SBATCH --output=slurm-%x-%A_%a.out
set -euo pipefail

if [ $# -lt 2 ]; then
  echo "usage: $0 MANIFEST OUT [SHARDS]" >&2
  exit 2
fi
MANIFEST=$1
OUT=$2
SHARDS=${3:-8}
MCVO=${MCVO:-build/mcvo}
JOBS=${MCVO_JOBS:-1}

if [ -n "${SLURM_ARRAY_TASK_ID:-}" ]; then
  # One task of the array: one shard of the runs.
  exec "$MCVO" batch --manifest "$MANIFEST" --out "$OUT" --shard "$SLURM_ARRAY_TASK_ID/$SHARDS" --jobs "$JOBS"
fi
if [ "${MCVO_SLURM_STEP:-}" = summary ]; then
  # After the array: the summary of all runs.
  exec "$MCVO" batch --manifest "$MANIFEST" --out "$OUT" --summary-only
fi

# On the login node: check the manifest, then submit. Slurm runs a copy of
# this script, so every path is made absolute first.
absolute() { case "$1" in /*) echo "$1" ;; *) echo "$PWD/$1" ;; esac; }
MANIFEST=$(absolute "$MANIFEST")
OUT=$(absolute "$OUT")
MCVO=$(absolute "$MCVO")
case "$SHARDS" in '' | *[!0-9]* | 0) echo "$0: SHARDS must be a positive integer, got '$SHARDS'" >&2; exit 2 ;; esac
[ -x "$MCVO" ] || { echo "$0: $MCVO is not an executable (set MCVO)" >&2; exit 2; }
# --summary-only runs nothing: it validates the manifest (exit 3 with the
# file and JSON path when it is bad) and writes a first summary (exit 4 while
# runs are missing).
status=0
"$MCVO" batch --manifest "$MANIFEST" --out "$OUT" --summary-only > /dev/null || status=$?
if [ "$status" -ne 0 ] && [ "$status" -ne 4 ]; then exit "$status"; fi
export MCVO MCVO_JOBS=$JOBS
array_id=$(sbatch --parsable --array=0-$((SHARDS - 1)) "$0" "$MANIFEST" "$OUT" "$SHARDS")
array_id=${array_id%%;*}
summary_id=$(sbatch --parsable --dependency=afterany:"$array_id" --job-name=mcvo-batch-summary \
  --cpus-per-task=1 --export=ALL,MCVO_SLURM_STEP=summary "$0" "$MANIFEST" "$OUT" "$SHARDS")
echo "submitted array job $array_id ($SHARDS tasks) and summary job $summary_id; summary: $OUT/summary.md"
