#!/usr/bin/env bash
# tools/slurm_batch.sh on a real (one-node) Slurm, end to end (ctest label
# `cluster`; issue 59). Starts its own Slurm under a temporary folder
# (tests/cluster/one_node_slurm.sh), stopped at the end also on failure.
#
#   tests/cluster/slurm_cluster_test.sh MCVO SOURCE_DIR
#
# Exit 0 passed, 1 failed, 77 (ctest SKIP_RETURN_CODE) when the Slurm or
# munge binaries are missing. MCVO_CLUSTER_KEEP=1 keeps the folder.
set -euo pipefail
PATH=$PATH:/usr/sbin:/sbin
MCVO=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
SRC=$(cd "$2" && pwd)
BATCH=$SRC/tools/slurm_batch.sh
SLURM=$SRC/tests/cluster/one_node_slurm.sh

for bin in munged slurmctld slurmd sbatch sinfo squeue scontrol scancel; do
  if ! command -v "$bin" > /dev/null; then
    echo "SKIP: $bin not found: the cluster test needs Debian's slurm-wlm and munge (make deps)"
    exit 77
  fi
done
[ "$(id -u)" = 0 ] || { echo "FAIL: the one-node Slurm needs root (slurmd starts the jobs)"; exit 1; }
# Not the environment of a Slurm job this test may itself run in.
while read -r var; do unset "$var"; done < <(env | sed -n 's/^\(SLURM_[A-Z_]*\)=.*/\1/p')

T=$(mktemp -d "${TMPDIR:-/tmp}/mcvo-cluster.XXXXXX")
started=$(date +%s)
cleanup() {
  local rc=$?
  "$SLURM" stop "$T/slurm" || true
  if [ "$rc" -ne 0 ]; then
    echo "--- logs (failed with $rc)"
    tail -n 30 "$T"/logs/* "$T"/slurm/log/*.log 2> /dev/null || true
  fi
  if [ "${MCVO_CLUSTER_KEEP:-0}" = 1 ]; then echo "kept $T"; else rm -rf "$T"; fi
  echo "cluster test: $(($(date +%s) - started)) s"
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

fail() { echo "FAIL: $*"; exit 1; }
check() { # check DESCRIPTION COMMAND...
  local what=$1; shift
  if "$@"; then echo "ok: $what"; else fail "$what"; fi
}

eval "$("$SLURM" start "$T/slurm")"
export SLURM_CONF
CPUS=$(sinfo -h -N -o '%c' | head -n 1)
MEM=$(sinfo -h -N -o '%m' | head -n 1)
echo "one-node Slurm: $CPUS CPUs, ${MEM}M, partition batch (MaxTime 60 min)"

# Jobs: wait until they have all ended; their state from scontrol.
wait_ended() { # wait_ended SECONDS JOBID...
  local limit=$1; shift
  local deadline=$(($(date +%s) + limit)) ids
  ids=$(IFS=,; echo "$*")
  while [ -n "$(squeue -h -o %i -j "$ids" 2> /dev/null)" ]; do
    if [ "$(date +%s)" -gt "$deadline" ]; then
      squeue -j "$ids" -o '%i %T %r' || true
      fail "jobs $ids still not ended after $limit s"
    fi
    sleep 0.2
  done
}
state() { # state JOBID [TASK]: JobState and ExitCode, "FAILED 4:0"
  scontrol show job -o "$1" | while read -r line; do
    if [ -z "${2:-}" ] || [[ " $line " == *" ArrayTaskId=$2 "* ]]; then
      sed -n 's/.* JobState=\([^ ]*\) .* ExitCode=\([^ ]*\) .*/\1 \2/p' <<< " $line "
    fi
  done
}
submit() { # submit ARGS...: sets ARRAY and SUMMARY from the script's line
  local line
  line=$("$BATCH" --mcvo "$MCVO" --cpus 1 --mem 1G --time 10 --log-dir "$T/logs" "$@")
  echo "$line"
  ARRAY=$(sed -n 's/^submitted array job \([0-9]*\) .*/\1/p' <<< "$line")
  SUMMARY=$(sed -n 's/.* and summary job \([0-9]*\);.*/\1/p' <<< "$line")
  [ -n "$ARRAY" ] && [ -n "$SUMMARY" ] || fail "no job ids in: $line"
}
log() { cat "$T/logs/slurm-mcvo-batch-$1.out"; }
no_staging() { [ -z "$(find "$1" -maxdepth 1 -name '*.tmp-*' -print -quit)" ]; }
strip_fps() { sed 's/,[^,]*$//' "$1"; } # frames_per_second, the last column: wall clock

# Data: a tiny render for the runs, a longer one for the run that is cancelled.
cd "$T"
"$MCVO" synth --preset mono --frames 12 --image-scale 0.25 --samples 1 --seed 3 --out data/short > synth.log 2>&1
"$MCVO" synth --preset mono --frames 240 --image-scale 0.25 --samples 1 --seed 3 --out data/long > synth_long.log 2>&1 &
synth_long=$!
mkdir -p logs
cat > runs.json << 'EOF'
{"runs": [
  {"name": "r0", "dataset": {"root": "data/short"}, "threads": 1},
  {"name": "r1", "dataset": {"root": "data/short"}, "max_frames": 10, "threads": 1},
  {"name": "bad", "dataset": {"root": "data/missing"}},
  {"name": "r3", "dataset": {"root": "data/short"}}
]}
EOF
# Shards: task 0 takes r0 and bad, task 1 r1 and r3.

# 1. Requests no node can satisfy are refused at submission, with one line.
jobs_before=$(squeue -h -o %i | wc -l)
for request in "--cpus $((CPUS + 1))" "--mem $((MEM + 1024))M" "--time 2:00:00" "--partition nosuch"; do
  rc=0
  # shellcheck disable=SC2086
  "$BATCH" --mcvo "$MCVO" --mem 1G --time 10 $request runs.json out 2 > refused.out 2> refused.err || rc=$?
  check "refused at submission: $request (exit $rc: $(cat refused.err))" \
    test "$rc" -eq 3 -a "$(wc -l < refused.err)" -eq 1 -a ! -s refused.out
done
check "nothing submitted by the refused requests" test "$(squeue -h -o %i | wc -l)" -eq "$jobs_before"
"$BATCH" --mcvo "$MCVO" --cpus 1 --mem 1G --time 10 --dry-run runs.json out 2 > dry.out
check "--dry-run prints the two sbatch lines" test "$(grep -c '^sbatch ' dry.out)" -eq 2
check "--dry-run's summary job has its own small limits" \
  grep -q -- '--job-name=mcvo-batch-summary --partition=batch --cpus-per-task=1 --mem=1G --time=00:30:00' dry.out

# 2. The array: every task ends, the failing run is named, the array's state says so.
submit runs.json out 2
wait_ended 120 "$ARRAY" "$SUMMARY"
check "task 0 (r0, bad) FAILED with exit 4: $(state "$ARRAY" 0)" test "$(state "$ARRAY" 0)" = "FAILED 4:0"
check "task 1 (r1, r3) COMPLETED: $(state "$ARRAY" 1)" test "$(state "$ARRAY" 1)" = "COMPLETED 0:0"
check "the summary job FAILED with exit 4 (a run failed): $(state "$SUMMARY")" test "$(state "$SUMMARY")" = "FAILED 4:0"
check "task 0's log names the failing run" grep -q 'batch: \[2/2\] bad: failed: .*data/missing: dataset folder does not exist' "logs/slurm-mcvo-batch-${ARRAY}_0.out"
check "the merged summary names the failing run" grep -q '^| bad | failed: ' out/summary.md
check "the summary job's log is slurm-mcvo-batch-summary-<job>.out" test -s "logs/slurm-mcvo-batch-summary-$SUMMARY.out"
check "no log named with %a outside the array" test -z "$(find logs -name '*4294967294*')"
check "r3 (no thread count) ran on SLURM_CPUS_PER_TASK=1 thread of the ${CPUS}-CPU node" \
  eval "sed -n '/ r3: started/,/ r3: ok/p' logs/slurm-mcvo-batch-${ARRAY}_1.out | grep -q 'tracking images, 1 threads'"
check "no staging folder left" no_staging out

# The merged summary equals what mcvo batch alone writes (timings aside).
SLURM_CPUS_PER_TASK=1 "$MCVO" batch --manifest runs.json --out alone > alone.log 2>&1 || true
check "merged summary.csv == mcvo batch alone's (frames_per_second aside)" \
  diff <(strip_fps out/summary.csv) <(strip_fps alone/summary.csv)

# 3. Resubmission redoes only the failed run (its dataset now exists).
cp -r data/short data/missing
r0_before=$(stat -c '%i %Y' out/r0/run.json)
submit runs.json out 2
wait_ended 120 "$ARRAY" "$SUMMARY"
check "resubmitted tasks and summary COMPLETED" \
  test "$(state "$ARRAY" 0)/$(state "$ARRAY" 1)/$(state "$SUMMARY")" = "COMPLETED 0:0/COMPLETED 0:0/COMPLETED 0:0"
check "the failed run is redone" grep -q 'batch: \[2/2\] bad: ok$' "logs/slurm-mcvo-batch-${ARRAY}_0.out"
for run in r0 r1 r3; do
  task=$([ "$run" = r0 ] && echo 0 || echo 1)
  check "$run skipped (up to date), never 'started'" \
    eval "grep -q ' $run: skipped (up to date)' logs/slurm-mcvo-batch-${ARRAY}_$task.out && ! grep -q ' $run: started' logs/slurm-mcvo-batch-${ARRAY}_$task.out"
done
check "r0's folder untouched" test "$(stat -c '%i %Y' out/r0/run.json)" = "$r0_before"
check "the merged summary: 1 ok, 3 skipped" grep -q '^4 runs: 1 ok, 3 skipped (up to date), 0 failed, 0 not run, 0 stale' out/summary.md

# 4. A task cancelled mid-run; a second submission while it runs.
wait "$synth_long" || { cat synth_long.log; fail "synth of the long sequence"; }
# The slow run must still be running when the test acts on it, however fast
# the machine: a config that tracks about 20 times the features (about 20 s
# on one core of the 2-core test machine, where the default takes 2 s).
cat > slow_config.json <<'CONFIG'
{"frontend": {"max_features_pinhole": 2000, "min_distance_px": 2, "pixel_scale_reference_px": 0},
 "backend": {"max_iterations": 50}}
CONFIG
echo '{"runs": [{"name": "slow", "dataset": {"root": "data/long"}, "config": "slow_config.json", "threads": 1}]}' > slow.json
wait_staging() { # the run has started writing
  local deadline=$(($(date +%s) + 60))
  until [ -n "$(find slow -maxdepth 1 -name 'slow.tmp-*' -print -quit 2> /dev/null)" ]; do
    [ "$(date +%s)" -le "$deadline" ] || fail "slow never started: $(state "$ARRAY" 0)"
    sleep 0.05
  done
}
submit slow.json slow 1
first=$ARRAY first_summary=$SUMMARY
wait_staging
second=''
if [ "$CPUS" -ge 2 ]; then
  submit slow.json slow 1
  second=$ARRAY second_summary=$SUMMARY
  second_log=logs/slurm-mcvo-batch-${second}_0.out
  deadline=$(($(date +%s) + 60))
  until grep -q 'batch: \[1/1\] slow: ' "$second_log" 2> /dev/null; do
    [ "$(date +%s)" -le "$deadline" ] || fail "the second submission's task never reported: $(state "$second" 0)"
    sleep 0.05
  done
  check "the first task still runs it: $(state "$first" 0)" test "$(state "$first" 0)" = "RUNNING 0:0"
else
  echo "note: one CPU: the second-submission check needs two tasks at once, not run"
fi
scancel "${first}_0"
if [ -n "$second" ]; then
  check "a second submission does not run it twice: 'failed: being written by another mcvo'" \
    grep -q 'batch: \[1/1\] slow: failed: being written by another mcvo: ' "$second_log"
  wait_ended 60 "$second" "$second_summary"
  check "the second task FAILED with exit 4: $(state "$second" 0)" test "$(state "$second" 0)" = "FAILED 4:0"
fi
wait_ended 60 "$first" "$first_summary"
check "the cancelled task is CANCELLED: $(state "$first" 0)" test "$(state "$first" 0 | cut -d' ' -f1)" = CANCELLED
check "the cancelled run is not marked done (no run.json)" test ! -e slow/slow/run.json
check "the cancelled run left no staging folder" no_staging slow
check "the summary after the cancel says 'not run'" grep -q '^| slow | not run (cancelled by signal 15 while running)' slow/summary.md
# Killed outright (SIGKILL, as the OOM killer or a lost node: nothing can
# clean up; scancel itself always sends SIGTERM first), then redone.
submit slow.json slow 1
wait_staging
staging=$(find slow -maxdepth 1 -name 'slow.tmp-*' -print -quit)
kill -KILL "${staging##*.tmp-}"
wait_ended 60 "$ARRAY" "$SUMMARY"
check "the killed task FAILED: $(state "$ARRAY" 0)" test "$(state "$ARRAY" 0 | cut -d' ' -f1)" = FAILED
check "a killed task leaves its staging folder (a dead process's)" test -d "$staging"
check "the killed run is not marked done" test ! -e slow/slow/run.json
submit slow.json slow 1
wait_ended 120 "$ARRAY" "$SUMMARY"
check "the redo COMPLETED: $(state "$ARRAY" 0), summary $(state "$SUMMARY")" \
  test "$(state "$ARRAY" 0)/$(state "$SUMMARY")" = "COMPLETED 0:0/COMPLETED 0:0"
check "the redo finished the run" test -s slow/slow/run.json
check "the redo removed the dead task's staging folder" no_staging slow
check "the merged summary: 1 ok" grep -q '^1 runs: 1 ok, ' slow/summary.md
echo "PASS"
