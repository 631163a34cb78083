#!/usr/bin/env bash
# Speed levers (issue 17): what each optional stage of a full-resolution
# 4-camera run costs in time and buys in accuracy, switched off one after the
# other on the same sequences. Writes results/speed_levers.csv and
# results/speed_levers.md.
#
#   tools/bench_speed_levers.sh [FRAMES] [MCVO] [SCRATCH]
#       defaults: 120 frames, build/mcvo, ${TMPDIR:-/tmp}/mcvo_bench_levers
#
# Data: six renders of the kitti360 preset at full resolution (two 1408x376
# pinholes, two 1400x1400 MEI fisheyes), FRAMES frames at 10 Hz each, four
# scenes, seeds 13, 21, 22, 383, 384, 385, with noise, blur and exposure
# changes (see SEQUENCES). Config: config/kitti360_4cam.json, then cumulative
# steps (STEPS): each keeps the ones before it switched off. Per sequence and
# step, on THREADS threads (default 2): `mcvo run`'s wall clock and CPU
# seconds (user + system, all threads), the odometry stage's own frames/s
# (run.json: frames over odometry_s_total, without start-up, loop closure,
# refinement and outputs), ATE (% of path, SE3) and scale error. Decode-only
# time of each sequence (`mcvo info --decode`) is the ratio's baseline, as in
# tools/bench_throughput.sh. Run on an idle machine: wall clock varies by a
# few percent from run to run.
set -euo pipefail
cd "$(dirname "$0")/.."
FRAMES=${1:-120}
MCVO=${2:-build/mcvo}
SCRATCH=${3:-${TMPDIR:-/tmp}/mcvo_bench_levers}
THREADS=${THREADS:-2}
OUT_MD=results/speed_levers.md
OUT_CSV=results/speed_levers.csv
mkdir -p "$SCRATCH"

SEQUENCES=(
  "urban_s13 --scene urban --seed 13 --noise 1"
  "block_s21 --scene urban_block --seed 21 --noise 1"
  "indoor_s22 --scene indoor --seed 22 --noise 2"
  "open_s383 --scene open --seed 383 --noise 1"
  "urban_s384 --scene urban --seed 384 --noise 2 --motion-blur 3"
  "block_s385 --scene urban_block --seed 385 --noise 1 --exposure-changes"
)
# name|python statements on the config d (s(path, value) sets a key); each
# step adds its statements to those of the steps before it.
STEPS=(
  "default|pass"
  "detect_missing_0.5|s('frontend.detect_missing_fraction', 0.5)"
  "no_clahe|s('frontend.clahe.enabled', False)"
  "no_anchor|s('frontend.anchor.enabled', False)"
  "cross_every_8|s('frontend.cross_camera.rematch_every', 8)"
  "no_global_ba|s('refine.enabled', False)"
  "no_loops_no_colmap|s('loop.enabled', False); s('colmap.enabled', False)"
)

render() {  # name synth-args... -> prints the sequence folder
  local name=$1 seq="$SCRATCH/$1-$FRAMES"
  shift
  if [[ ! -f "$seq/frames.csv" ]]; then
    echo "rendering $seq ..." >&2
    "$MCVO" synth --preset kitti360 --frames "$FRAMES" --image-scale 1 --samples 1 --threads "$THREADS" \
      --force --out "$seq" "$@" >&2
  fi
  echo "$seq"
}

# shellcheck source=tools/bench_common.sh
source tools/bench_common.sh  # seconds_of

write_config() {  # step-index out.json
  local edits="" i
  for ((i = 0; i <= $1; ++i)); do edits+="${STEPS[$i]#*|}"$'\n'; done
  python3 - "$2" "$edits" <<'PY'
import json, sys
d = json.load(open("config/kitti360_4cam.json"))
def s(path, value):
    keys, node = path.split("."), d
    for k in keys[:-1]:
        node = node.setdefault(k, {})
    node[keys[-1]] = value
exec(sys.argv[2])
json.dump(d, open(sys.argv[1], "w"), indent=1)
PY
}

cams=image_00,image_01,image_02,image_03
echo "sequence,step,frames,decode_s,run_s,run_cpu_s,decode_fps,run_fps,run_over_decode,cpu_s_per_frame,odometry_fps,posed,scale,ate_percent,scale_error_percent" \
  > "$OUT_CSV"
for spec in "${SEQUENCES[@]}"; do
  read -r -a args <<< "$spec"
  name=${args[0]}
  seq=$(render "$name" "${args[@]:1}")
  find "$seq" -type f -exec cat {} + > /dev/null  # page cache: every command reads the same way
  decode=$(seconds_of "$MCVO" info --dataset "$seq" --cameras "$cams" --decode --threads "$THREADS")
  for ((i = 0; i < ${#STEPS[@]}; ++i)); do
    step=${STEPS[$i]%%|*}
    config="$SCRATCH/$name-$i.json"
    out="$SCRATCH/run_$name-$i"
    write_config "$i" "$config"
    run=$(seconds_of "$MCVO" run --dataset "$seq" --config "$config" --threads "$THREADS" --force --out "$out")
    python3 - "$out/run.json" "$name" "$step" "$FRAMES" "$decode" "$run" >> "$OUT_CSV" <<'PY'
import json, sys
run_json, name, step, frames, decode, run = sys.argv[1:]
d = json.load(open(run_json))
r, t = d["result"], d["timing"]
(decode, _), (run, run_cpu) = (map(float, s.split()) for s in (decode, run))
frames = int(frames)
print(",".join(str(x) for x in [name, step, frames, f"{decode:.3f}", f"{run:.3f}", f"{run_cpu:.3f}",
      f"{frames / decode:.2f}", f"{frames / run:.2f}", f"{run / decode:.2f}", f"{run_cpu / frames:.4f}",
      f"{frames / t['odometry_s_total']:.2f}", r["posed_frames"], r.get("scale", "metric"),
      f"{r.get('ate_percent_of_path', float('nan')):.4f}",
      f"{r['scale_error_percent']:.4f}" if "scale_error_percent" in r else "-"]))
PY
    tail -1 "$OUT_CSV" >&2
  done
done

python3 - "$OUT_CSV" "$OUT_MD" "$FRAMES" "$THREADS" "$(git rev-parse --short HEAD)" <<'PY'
import csv, statistics, sys
from collections import OrderedDict
rows = list(csv.DictReader(open(sys.argv[1])))
frames, threads, commit = sys.argv[3], sys.argv[4], sys.argv[5]
steps = OrderedDict()
for r in rows:
    steps.setdefault(r["step"], []).append(r)
base = {r["sequence"]: r for r in steps["default"]}
def med(v): return statistics.median(v)
def f(x, p=2): return f"{x:.{p}f}"
out = []
out.append("# Speed levers: what each optional stage costs and buys (issue 17)\n")
out.append(f"`tools/bench_speed_levers.sh {frames}` at commit {commit}, {threads} threads, on the machine it ran on: "
           f"{len(base)} full-resolution renders of the kitti360 preset (4 cameras, {frames} frames at 10 Hz each), "
           "config/kitti360_4cam.json, then each step switched off on top of the steps before it. "
           "Wall clock and CPU seconds of the whole `mcvo run` (start-up and outputs included); "
           "odometry frames/s: run.json's frames over odometry_s_total (the frontend and the window "
           "estimator alone); x decode: the run's wall time over the decode-only time of the same images. "
           "ATE % of path (SE3) and scale error: ratios to the default on the same sequence.\n")
out.append("| step (cumulative) | run fps median (worst) | x decode median | CPU s/frame median | odometry fps median "
           "| all frames posed | ATE ratio median (worst) | scale error ratio median (worst) |")
out.append("|---|---|---|---|---|---|---|---|")
for step, rs in steps.items():
    fps = [float(r["run_fps"]) for r in rs]
    ate = [float(r["ate_percent"]) / float(base[r["sequence"]]["ate_percent"]) for r in rs]
    sc = [float(r["scale_error_percent"]) / float(base[r["sequence"]]["scale_error_percent"])
          for r in rs if r["scale_error_percent"] != "-" and base[r["sequence"]]["scale_error_percent"] != "-"]
    posed = sum(int(r["posed"]) == int(r["frames"]) for r in rs)
    out.append(f"| {step} | {f(med(fps))} ({f(min(fps))}) | {f(med([float(r['run_over_decode']) for r in rs]))} | "
               f"{f(med([float(r['cpu_s_per_frame']) for r in rs]), 3)} | "
               f"{f(med([float(r['odometry_fps']) for r in rs]))} | {posed}/{len(rs)} | "
               f"{f(med(ate))} ({f(max(ate))}) | " + (f"{f(med(sc))} ({f(max(sc))})" if sc else "-") + " |")
out.append("\nPer sequence:\n")
out.append("| sequence | step | run fps | x decode | CPU s/frame | odometry fps | posed | ATE % | scale error % |")
out.append("|---|---|---|---|---|---|---|---|---|")
for r in rows:
    out.append(f"| {r['sequence']} | {r['step']} | {r['run_fps']} | {r['run_over_decode']} | {r['cpu_s_per_frame']} | "
               f"{r['odometry_fps']} | {r['posed']}/{r['frames']} | {r['ate_percent']} | {r['scale_error_percent']} |")
open(sys.argv[2], "w").write("\n".join(out) + "\n")
PY
echo "wrote $OUT_MD and $OUT_CSV" >&2
