#!/usr/bin/env bash
# Speed levers on the real recordings (issue 58 with issue 56's guard): the
# existing config knobs that skip or shrink work, each on its own, run on
# every real sample with CPU seconds per frame beside the accuracy, so that
# no speed is bought with hidden accuracy. Writes results/real_speed_levers.md.
#
#   tools/bench_real_levers.sh [MCVO] [SCRATCH]
#       defaults: build/mcvo, ${TMPDIR:-/tmp}/mcvo_bench_real_levers
#   env DATA    the real samples (default ../shared/data/real)
#   env REPEAT  runs per sample and lever (default 3): CPU s/frame is their
#               median; the trajectory is compared byte for byte across them.
#               The repeats are interleaved (lever 1, 2, ..., then again), so
#               a machine that slows down for a while slows every lever alike
#   env LEVERS_FILE  a file of levers to run instead of the built-in list, one
#               per line as `name|override JSON` (# comments and empty
#               lines skipped); e.g. tools/levers/feature_budget.txt
#   env OUT_MD  the table's file (default results/real_speed_levers.md)
#
# Each lever is a config override on top of the built-in defaults (LEVERS
# below); every sample that `mcvo info --dataset` reads and that has ground
# truth runs at --threads 1. CPU seconds: user + system of `mcvo run` alone
# (tools/bench_common.sh seconds_of), start-up and outputs included, over the
# posed frames. Scoring as tools/bench_real.sh: SE3 / Sim3 ATE % of the
# matched ground-truth path, scale error % = 100 |1/s - 1|; a still sample:
# the ATE in mm and the estimate's path length in mm. A one-camera sample has
# an arbitrary scale: Sim3 only.
set -euo pipefail
cd "$(dirname "$0")/.."
COMMAND_LINE="tools/bench_real_levers.sh${*:+ $*}"
MCVO=${1:-build/mcvo}
SCRATCH=${2:-${TMPDIR:-/tmp}/mcvo_bench_real_levers}
DATA=${DATA:-../shared/data/real}
REPEAT=${REPEAT:-3}
PY=/usr/bin/python3
[[ -d $DATA ]] || { echo "bench_real_levers.sh: no sample folder $DATA" >&2; exit 1; }
mkdir -p "$SCRATCH"
# shellcheck source=tools/bench_common.sh
source tools/bench_common.sh  # seconds_of

# name|override JSON (merged into the built-in defaults)
LEVERS=(
  'defaults|{}'
  'cross_camera.rematch_every 3|{"frontend":{"cross_camera":{"rematch_every":3}}}'
  'cross_camera.rematch_every 4|{"frontend":{"cross_camera":{"rematch_every":4}}}'
  'cross_camera.rematch_every 8|{"frontend":{"cross_camera":{"rematch_every":8}}}'
  'detection_max_megapixels 0.25|{"frontend":{"detection_max_megapixels":0.25}}'
  'detect_missing_fraction 0.25|{"frontend":{"detect_missing_fraction":0.25}}'
  'loop.feature_max_megapixels 0.25|{"loop":{"feature_max_megapixels":0.25}}'
  'rematch_every 4 + loop features 0.25 Mpx|{"frontend":{"cross_camera":{"rematch_every":4}},"loop":{"feature_max_megapixels":0.25}}'
)
OUT_MD=${OUT_MD:-results/real_speed_levers.md}
if [[ -n ${LEVERS_FILE:-} ]]; then
  [[ -f $LEVERS_FILE ]] || { echo "bench_real_levers.sh: no levers file $LEVERS_FILE" >&2; exit 1; }
  COMMAND_LINE="LEVERS_FILE=$LEVERS_FILE $COMMAND_LINE"
  mapfile -t LEVERS < <(grep -v -e '^[[:space:]]*#' -e '^[[:space:]]*$' "$LEVERS_FILE")
  for lever in "${LEVERS[@]}"; do
    [[ $lever == *'|'* ]] || { echo "bench_real_levers.sh: not 'name|JSON': $lever" >&2; exit 1; }
  done
fi
[[ $OUT_MD == results/real_speed_levers.md ]] || COMMAND_LINE="OUT_MD=$OUT_MD $COMMAND_LINE"

LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg)
ROWS=$SCRATCH/rows.tsv
: > "$ROWS"
for dir in "$DATA"/*/; do
  dir=${dir%/}
  sample=$(basename "$dir")
  "$MCVO" info --dataset "$dir" > /dev/null 2>&1 || continue
  gt=-
  for g in groundtruth.tum groundtruth_tum.txt mav0/state_groundtruth_estimate0/data.csv; do
    [[ -f $dir/$g ]] && { gt=$dir/$g; break; }
  done
  [[ $gt == - ]] && continue
  declare -A cpus=()
  for ((r = 1; r <= REPEAT; r++)); do
    for k in "${!LEVERS[@]}"; do
      name=${LEVERS[$k]%%|*}
      config=$SCRATCH/lever_$k.json
      printf '%s\n' "${LEVERS[$k]#*|}" > "$config"
      out=$SCRATCH/run_${k}_${sample}_$r
      read -r _ cpu < <(seconds_of "$MCVO" run --dataset "$dir" --config "$config" --threads 1 --force --out "$out")
      cpus[$k]="${cpus[$k]:-}${cpus[$k]:+ }$cpu"
      cmp -s "$out/trajectory.tum" "$SCRATCH/run_${k}_${sample}_1/trajectory.tum" ||
        { echo "bench_real_levers.sh: $sample, $name: run $r's trajectory differs from run 1's" >&2; exit 1; }
      echo "$sample, $name, run $r: CPU s $cpu" >&2
    done
  done
  for k in "${!LEVERS[@]}"; do
    name=${LEVERS[$k]%%|*}
    out=$SCRATCH/run_${k}_${sample}_1
    for align in se3 sim3; do
      "$MCVO" eval --gt "$gt" --est "$out/trajectory.tum" --align $align --force --out "$out/eval_$align" > /dev/null
    done
    printf '%s\t%s\t%s\t%s\n' "$sample" "$name" "$out" "${cpus[$k]}" >> "$ROWS"
  done
  unset cpus
done
LOAD_AFTER=$(cut -d' ' -f1-3 /proc/loadavg)

$PY - "$ROWS" "$COMMAND_LINE" "$MCVO" "$REPEAT" "$LOAD_BEFORE" "$LOAD_AFTER" > "$OUT_MD" <<'PY'
import datetime, json, statistics, subprocess, sys
rows, command_line, mcvo, repeat, load_before, load_after = sys.argv[1:]
commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
version = subprocess.run([mcvo, "version"], capture_output=True, text=True).stdout.split("\n")[0].strip()
now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
print("# Speed levers on the real recordings: CPU per frame beside the accuracy\n")
print(f"`{command_line}`\n")
print(f"{now}, {version}, commit {commit}; machine: {subprocess.run(['nproc'], capture_output=True, text=True).stdout.strip()} cores, "
      f"load average {load_before} before, {load_after} after. The script's header says what is measured.\n")
print(f"CPU s/frame: the median of {repeat} runs (user + system of `mcvo run --threads 1` over the posed frames, "
      "start-up included); the runs' spread beside it. The trajectories of the repeated runs are identical (checked).\n")
print("| sample | lever | posed | CPU s/frame | CPU spread | SE3 ATE % | Sim3 ATE % | scale error % |")
print("|---|---|---|---|---|---|---|---|")
for line in open(rows):
    sample, name, out, cpus = line.rstrip("\n").split("\t")
    run = json.load(open(f"{out}/run.json"))
    posed = run["result"]["posed_frames"]
    cpu = [float(c) / max(posed, 1) for c in cpus.split()]
    ev = {a: json.load(open(f"{out}/eval_{a}/eval.json")) for a in ("se3", "sim3")}
    path = ev["se3"]["rpe"]["gt_path_length_m"]
    metric = run["result"].get("scale", "metric") == "metric"
    if path < 0.1:
        est_path = ev["se3"]["start_end"]["est_path_length_m"]
        cols = [f"{1000 * ev['se3']['ate']['translation_m']['rmse']:.2f} mm", "-", f"path {1000 * est_path:.1f} mm"]
    else:
        pct = {a: 100 * ev[a]["ate"]["translation_m"]["rmse"] / ev[a]["rpe"]["gt_path_length_m"] for a in ev}
        se3 = f"{pct['se3']:.3f}" if metric else "arbitrary scale"
        scale = f"{ev['sim3']['scale']['scale_error_percent']:.2f}" if metric else "arbitrary scale"
        cols = [se3, f"{pct['sim3']:.3f}", scale]
    print(f"| {sample} | {name} | {posed} | {statistics.median(cpu):.4f} | {min(cpu):.4f}-{max(cpu):.4f} | " + " | ".join(cols) + " |")
PY
cat "$OUT_MD"
