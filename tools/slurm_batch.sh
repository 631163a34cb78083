#!/usr/bin/env bash
# `mcvo batch` spread over a Slurm cluster: a job array of SHARDS tasks, then
# one small job that gathers the summary of every run (docs/batch-and-regress.md).
#
#   tools/slurm_batch.sh [OPTIONS] MANIFEST OUT [SHARDS]
#
# Run on the login node. The cluster's shape is given as options (nothing to
# edit in this file):
#   --partition NAME  partition of every job (default: the cluster's default partition)
#   --cpus N          CPUs per task (default 1)
#   --mem SIZE        memory per task, as sbatch --mem: 2G, 1500M, ... (default 2G)
#   --time LIMIT      time limit per task, as sbatch --time: 30, 4:00:00, 1-00:00:00 (default 4:00:00)
#   --account NAME    account to charge (sbatch --account; default: none given)
#   --jobs J          runs at the same time in each task (mcvo batch --jobs; default $MCVO_JOBS or 1)
#   --log-dir DIR     folder of the Slurm logs (default: the current folder)
#   --mcvo PATH       the mcvo executable (default $MCVO or build/mcvo)
#   --dry-run         check everything, print the two sbatch command lines, submit nothing
#
# What it submits:
#   1. an array of SHARDS tasks (default 8); task K runs
#        mcvo batch --manifest MANIFEST --out OUT --shard K/SHARDS --jobs J
#      (K = $SLURM_ARRAY_TASK_ID, 0-based: run i of the manifest goes to task i % SHARDS);
#      each run without a thread count of its own gets $SLURM_CPUS_PER_TASK / J
#      threads (mcvo reads $SLURM_CPUS_PER_TASK: under task/none the affinity
#      mask would be the whole node). Log: DIR/slurm-mcvo-batch-<array>_<K>.out;
#   2. a job that starts when the whole array has ended (afterany: also when
#      tasks failed or were cancelled), with small limits of its own (1 CPU,
#      1G, 30 minutes: it only reads JSON), running
#        mcvo batch --manifest MANIFEST --out OUT --summary-only
#      which writes OUT/summary.csv and OUT/summary.md from the run folders and
#      the status each task recorded; it exits 4 (job state FAILED) when a run
#      failed, was not run or is stale. Log: DIR/slurm-mcvo-batch-summary-<job>.out.
#
# Before submitting it checks the manifest (mcvo batch --summary-only: exit 3
# naming the file and JSON path when it is bad) and refuses, with one line and
# exit 3, a request that no node of the partition can satisfy (CPUs, memory,
# the partition's time and per-node limits; sinfo, scontrol show partition,
# then sbatch --test-only), instead of jobs that pend for ever.
#
# OUT must be on a file system that every node sees. Each run writes only its
# own folder OUT/<name>/ (staged, locked and renamed into place when complete:
# util/output_folder.h) and its record OUT/.batch/runs/<name>.json. Submitting
# the same command again resumes: finished runs that are up to date are
# skipped, so only failed, cancelled or changed runs run again. A run still
# being written by an earlier submission's task is not run twice: the later
# task reports it "failed: being written by another mcvo".
#
# Exit codes: 0 submitted (or --dry-run), 2 usage, 3 bad manifest or a request
# the cluster cannot satisfy, other: sbatch failed.
set -euo pipefail

usage() {
  sed -n '6,16p' "$0" | sed 's/^# \{0,1\}//' >&2
  echo "usage: $0 [--partition P] [--cpus N] [--mem SIZE] [--time LIMIT] [--account A] [--jobs J] [--log-dir DIR] [--mcvo PATH] [--dry-run] MANIFEST OUT [SHARDS]" >&2
  exit 2
}
fail() { echo "$0: $*" >&2; exit 3; }

PARTITION='' CPUS=1 MEM=2G TIME=4:00:00 ACCOUNT='' JOBS=${MCVO_JOBS:-1} LOG_DIR=. MCVO=${MCVO:-build/mcvo}
DRY_RUN=0 STEP=''
SUMMARY_MEM=1G SUMMARY_TIME=00:30:00
positional=()
while [ $# -gt 0 ]; do
  case "$1" in
    --partition | --cpus | --mem | --time | --account | --jobs | --log-dir | --mcvo | --step)
      [ $# -ge 2 ] || { echo "$0: $1 needs a value" >&2; usage; }
      case "$1" in
        --partition) PARTITION=$2 ;; --cpus) CPUS=$2 ;; --mem) MEM=$2 ;; --time) TIME=$2 ;;
        --account) ACCOUNT=$2 ;; --jobs) JOBS=$2 ;; --log-dir) LOG_DIR=$2 ;; --mcvo) MCVO=$2 ;;
        --step) STEP=$2 ;;
      esac
      shift 2 ;;
    --dry-run) DRY_RUN=1; shift ;;
    -h | --help) usage ;;
    --) shift; positional+=("$@"); break ;;
    -*) echo "$0: unknown option $1" >&2; usage ;;
    *) positional+=("$1"); shift ;;
  esac
done
[ ${#positional[@]} -ge 2 ] && [ ${#positional[@]} -le 3 ] || usage
MANIFEST=${positional[0]}
OUT=${positional[1]}
SHARDS=${positional[2]:-8}

# Inside Slurm (the script submits itself with --step): one task, or the summary.
case "$STEP" in
  task)
    echo "mcvo-batch: task ${SLURM_ARRAY_TASK_ID:-?}/$SHARDS of job ${SLURM_ARRAY_JOB_ID:-?} on $(hostname -s):" \
      "${SLURM_CPUS_PER_TASK:-?} CPUs, $JOBS run(s) at a time"
    exec "$MCVO" batch --manifest "$MANIFEST" --out "$OUT" --shard "$SLURM_ARRAY_TASK_ID/$SHARDS" --jobs "$JOBS"
    ;;
  summary)
    exec "$MCVO" batch --manifest "$MANIFEST" --out "$OUT" --summary-only
    ;;
  '') ;;
  *) echo "$0: --step: unknown step '$STEP'" >&2; exit 2 ;;
esac

# On the login node. Slurm runs a copy of this script, so every path is made
# absolute first.
absolute() { case "$1" in /*) echo "$1" ;; *) echo "$PWD/$1" ;; esac; }
positive() { case "$2" in '' | *[!0-9]* | 0*) echo "$0: $1 must be a positive integer, got '$2'" >&2; exit 2 ;; esac; }
positive SHARDS "$SHARDS"
positive --cpus "$CPUS"
positive --jobs "$JOBS"
MANIFEST=$(absolute "$MANIFEST")
OUT=$(absolute "$OUT")
MCVO=$(absolute "$MCVO")
LOG_DIR=$(absolute "$LOG_DIR")
[ -x "$MCVO" ] || { echo "$0: $MCVO is not an executable (--mcvo or MCVO)" >&2; exit 2; }

# Sizes and durations as Slurm writes them.
mem_mb() { # 2G -> 2048; a bare number is MB (sbatch --mem)
  local n=${1%[KkMmGgTt]} unit=${1#"${1%[KkMmGgTt]}"}
  case "$n" in '' | *[!0-9]*) return 1 ;; esac
  case "$unit" in
    K | k) echo $(((n + 1023) / 1024)) ;; '' | M | m) echo "$n" ;;
    G | g) echo $((n * 1024)) ;; T | t) echo $((n * 1024 * 1024)) ;;
  esac
}
seconds() { # Slurm time limit -> seconds; "infinite" / "UNLIMITED" -> empty
  local t=$1 days=0 h=0 m=0 s=0
  case "$t" in infinite | INFINITE | UNLIMITED | unlimited) echo ''; return 0 ;; esac
  case "$t" in *[!0-9:-]* | '') return 1 ;; esac
  if [[ $t == *-* ]]; then
    days=${t%%-*}; t=${t#*-}
    IFS=: read -r h m s <<<"$t"
  else
    local parts; IFS=: read -r -a parts <<<"$t"
    case ${#parts[@]} in
      1) m=${parts[0]} ;; 2) m=${parts[0]}; s=${parts[1]} ;; 3) h=${parts[0]}; m=${parts[1]}; s=${parts[2]} ;;
      *) return 1 ;;
    esac
  fi
  echo $(((10#${days:-0} * 24 + 10#${h:-0}) * 3600 + 10#${m:-0} * 60 + 10#${s:-0}))
}
MEM_MB=$(mem_mb "$MEM") || { echo "$0: --mem: expected a size such as 2G or 1500M, got '$MEM'" >&2; exit 2; }
TIME_S=$(seconds "$TIME") || { echo "$0: --time: expected a Slurm time such as 4:00:00 or 1-00:00:00, got '$TIME'" >&2; exit 2; }
[ -n "$TIME_S" ] || { echo "$0: --time: give a finite limit, got '$TIME'" >&2; exit 2; }

# Refuses what no node of the partition can run (sbatch would accept it and
# the jobs would pend for ever, reason PartitionConfig or Resources).
check_cluster() {
  local info
  info=$(scontrol show partition -o "$PARTITION" 2> /dev/null) ||
    fail "no partition '$PARTITION' (partitions: $(sinfo -h -o '%P' | tr -d '*' | sort -u | tr '\n' ' '))"
  field() { sed -n "s/.* $1=\([^ ]*\).*/\1/p" <<<" $info"; }
  local max_time max_cpus max_mem_node max_mem_cpu
  max_time=$(field MaxTime) max_cpus=$(field MaxCPUsPerNode)
  max_mem_node=$(field MaxMemPerNode) max_mem_cpu=$(field MaxMemPerCPU)
  local request="--cpus $CPUS --mem $MEM --time $TIME"
  if [ -n "$max_time" ]; then
    local max_s; max_s=$(seconds "$max_time" || echo '')
    if [ -n "$max_s" ] && [ "$TIME_S" -gt "$max_s" ]; then
      fail "refused: $request: --time $TIME exceeds partition $PARTITION's MaxTime=$max_time"
    fi
  fi
  if [[ $max_cpus =~ ^[0-9]+$ ]] && [ "$CPUS" -gt "$max_cpus" ]; then
    fail "refused: $request: --cpus $CPUS exceeds partition $PARTITION's MaxCPUsPerNode=$max_cpus"
  fi
  if [[ $max_mem_node =~ ^[0-9]+$ ]] && [ "$MEM_MB" -gt "$max_mem_node" ]; then
    fail "refused: $request: --mem $MEM exceeds partition $PARTITION's MaxMemPerNode=${max_mem_node}M"
  fi
  if [[ $max_mem_cpu =~ ^[0-9]+$ ]] && [ "$MEM_MB" -gt $((max_mem_cpu * CPUS)) ]; then
    fail "refused: $request: --mem $MEM exceeds partition $PARTITION's MaxMemPerCPU=${max_mem_cpu}M x $CPUS CPUs"
  fi
  # A node with enough CPUs and memory (sinfo: configured CPUs, RealMemory in MB).
  local fits=0 most_cpus=0 most_mem=0 node cpus mem
  while read -r node cpus mem; do
    mem=${mem%%+*} cpus=${cpus%%+*}
    [[ $cpus =~ ^[0-9]+$ && $mem =~ ^[0-9]+$ ]] || continue
    [ "$cpus" -gt "$most_cpus" ] && most_cpus=$cpus
    [ "$mem" -gt "$most_mem" ] && most_mem=$mem
    if [ "$cpus" -ge "$CPUS" ] && [ "$mem" -ge "$MEM_MB" ]; then fits=1; fi
  done < <(sinfo -h -N -p "$PARTITION" -o '%N %c %m')
  if [ "$fits" -eq 0 ]; then
    fail "refused: $request: no node of partition $PARTITION has $CPUS CPUs and ${MEM_MB}M" \
      "(the largest: $most_cpus CPUs, ${most_mem}M); give smaller --cpus / --mem"
  fi
  # What Slurm itself says (account, QOS, node features: what the above does not know).
  local test_only
  if ! test_only=$(sbatch --test-only "${task_options[@]}" --wrap true 2>&1); then
    fail "refused: $request: sbatch --test-only says: $(tail -n 1 <<<"$test_only")"
  fi
}

task_options=() summary_options=()
set_options() {
  local common=()
  [ -n "$PARTITION" ] && common+=(--partition="$PARTITION")
  [ -n "$ACCOUNT" ] && common+=(--account="$ACCOUNT")
  task_options=("${common[@]}" --cpus-per-task="$CPUS" --mem="$MEM" --time="$TIME")
  summary_options=("${common[@]}" --cpus-per-task=1 --mem="$SUMMARY_MEM" --time="$SUMMARY_TIME")
}

if command -v sinfo > /dev/null; then
  if [ -z "$PARTITION" ]; then
    PARTITION=$(sinfo -h -o '%P' | sed -n 's/\*$//p' | head -n 1)
    [ -n "$PARTITION" ] || fail "the cluster has no default partition: give --partition"
  fi
  set_options
  check_cluster
elif [ "$DRY_RUN" -eq 1 ]; then
  echo "$0: --dry-run: no Slurm here (sinfo not found): the request is not checked" >&2
  set_options
else
  fail "sinfo not found: is this a Slurm login node?"
fi

# --summary-only runs nothing: it validates the manifest (exit 3 with the
# file and JSON path when it is bad) and writes a first summary (exit 4 while
# runs are missing).
status=0
check_log=$(mktemp)
"$MCVO" batch --manifest "$MANIFEST" --out "$OUT" --summary-only > /dev/null 2> "$check_log" || status=$?
if [ "$status" -ne 0 ] && [ "$status" -ne 4 ]; then
  cat "$check_log" >&2
  rm -f "$check_log"
  exit "$status"
fi
rm -f "$check_log"

steps=(--mcvo "$MCVO" --jobs "$JOBS" -- "$MANIFEST" "$OUT" "$SHARDS")
array_cmd=(sbatch --parsable --array=0-$((SHARDS - 1)) --job-name=mcvo-batch "${task_options[@]}"
  --output="$LOG_DIR/slurm-%x-%A_%a.out" "$(absolute "$0")" --step task "${steps[@]}")
summary_cmd=(sbatch --parsable --dependency=afterany:ARRAY_JOB_ID --job-name=mcvo-batch-summary
  "${summary_options[@]}" --output="$LOG_DIR/slurm-%x-%j.out" "$(absolute "$0")" --step summary "${steps[@]}")
if [ "$DRY_RUN" -eq 1 ]; then
  printf '%q ' "${array_cmd[@]}"; echo
  printf '%q ' "${summary_cmd[@]}" | sed 's/ARRAY_JOB_ID/<array job id>/'; echo
  exit 0
fi
mkdir -p "$LOG_DIR"
array_id=$("${array_cmd[@]}")
array_id=${array_id%%;*}
summary_cmd=("${summary_cmd[@]/afterany:ARRAY_JOB_ID/afterany:$array_id}")
summary_id=$("${summary_cmd[@]}")
summary_id=${summary_id%%;*}
echo "submitted array job $array_id ($SHARDS tasks: $CPUS CPUs, $MEM, $TIME each on partition $PARTITION)" \
  "and summary job $summary_id; summary: $OUT/summary.md"
