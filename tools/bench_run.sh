#!/usr/bin/env bash
# End-to-end benchmark of `mcvo run` on the synthetic urban route (the
# closed 1.18 km drive of the kitti360 preset: 1575 frames at 10 Hz, half
# resolution, 1 grey level of image noise), shaped like Table I of the paper.
# Writes results/run_benchmark.md and results/run_benchmark.csv.
#
#   tools/bench_run.sh [MCVO] [SCRATCH]
#       defaults: build/mcvo, ${TMPDIR:-/tmp}/mcvo_bench_run
#
# The sequence is rendered once into SCRATCH (about 25 min on 2 cores) and
# reused. Runs (each on the whole route unless FRAMES is set):
#   kitti360_4cam, kitti360_3cam (no cross-camera matching: scale from the
#   rig constraint alone), kitti360_2cam (the stereo pair), each with the
#   Shi-Tomasi detector; then kitti360_4cam with ORB and with XFeat over the
#   first DETECTOR_FRAMES frames for the frame rate of each detector.
# Accuracy: `mcvo eval` inside `mcvo run`, SE3 alignment (no scale fitted):
# ATE rmse as % of the ground-truth path over the posed frames, and the scale
# error 100 |1/s - 1| of the Sim3 fit. Frames/s: wall clock of the whole run
# (decoding, frontend and back end pipelined on 2 threads), NOT deterministic:
# run on an otherwise idle machine. REUSE=1 keeps runs whose run.json exists.
set -euo pipefail
cd "$(dirname "$0")/.."
MCVO=${1:-build/mcvo}
SCRATCH=${2:-${TMPDIR:-/tmp}/mcvo_bench_run}
FRAMES=${FRAMES:-0}
DETECTOR_FRAMES=${DETECTOR_FRAMES:-300}
THREADS=${THREADS:-2}
SEQ="$SCRATCH/urban_kitti360_half"
mkdir -p "$SCRATCH" results

if [[ ! -f "$SEQ/frames.csv" ]]; then
  echo "rendering the urban route with the kitti360 rig at half resolution into $SEQ ..." >&2
  "$MCVO" synth --preset kitti360 --image-scale 0.5 --noise 1 --seed 1 --threads "$THREADS" --out "$SEQ" --force >&2
fi

run() {  # name, config, frames, extra flags...
  local name=$1 config=$2 frames=$3
  shift 3
  if [[ "${REUSE:-0}" == 1 && -f "$SCRATCH/$name/run.json" ]]; then
    echo "run $name: reusing $SCRATCH/$name" >&2
    return
  fi
  echo "run $name ..." >&2
  "$MCVO" run --dataset "$SEQ" --config "$config" --frames "$frames" --threads "$THREADS" \
    --out "$SCRATCH/$name" --force "$@" >&2
}

run 4cam config/kitti360_4cam.json "$FRAMES"
run 3cam config/kitti360_3cam.json "$FRAMES"
run 2cam config/kitti360_2cam.json "$FRAMES"
run 4cam_orb_short config/kitti360_4cam.json "$DETECTOR_FRAMES" --detector orb
run 4cam_shi_short config/kitti360_4cam.json "$DETECTOR_FRAMES"
MODEL=../shared/models/xfeat_480x640.onnx
if [[ -f "$MODEL" ]]; then
  run 4cam_xfeat_short config/kitti360_4cam.json "$DETECTOR_FRAMES" --detector xfeat --model "$MODEL"
fi

python3 - "$SCRATCH" "$SEQ" <<'PY'
import json, sys, os, math
scratch, seq = sys.argv[1], sys.argv[2]


def read_tum(path):
    poses = {}
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        v = line.split()
        poses[round(float(v[0]), 3)] = tuple(map(float, v[1:4]))
    return poses


gt = read_tum(os.path.join(seq, "groundtruth.tum"))


def local_scale_range(run_dir, step=50):
    """Min and max over 50-frame windows of estimated / true distance between the window's ends."""
    est = read_tum(os.path.join(run_dir, "trajectory.tum"))
    times = sorted(t for t in est if t in gt)
    ratios = []
    for i in range(0, len(times) - step, step):
        a, b = times[i], times[i + step]
        true = math.dist(gt[a], gt[b])
        if true > 1.0:
            ratios.append(math.dist(est[a], est[b]) / true)
    return (min(ratios), max(ratios)) if ratios else (float("nan"), float("nan"))


rows = []
for name in ["4cam", "3cam", "2cam", "4cam_shi_short", "4cam_orb_short", "4cam_xfeat_short"]:
    path = os.path.join(scratch, name, "run.json")
    if not os.path.exists(path):
        continue
    run = json.load(open(path))
    r, t, c = run["result"], run["timing"], run["config"]
    gba = r.get("global_ba") or {}
    vo_path = os.path.join(scratch, name, "eval_vo", "eval.json")
    vo = json.load(open(vo_path)) if os.path.exists(vo_path) else {}
    rows.append(dict(name=name, cameras=",".join(run["dataset"]["cameras"]), detector=c["frontend"]["detector"],
                     frames=r["frames"], posed=r["posed_frames"], segments=r["segments"],
                     path_m=r.get("gt_path_length_m", 0.0), ate_m=r.get("ate_rmse_m", float("nan")),
                     ate_pct=r.get("ate_percent_of_path", float("nan")),
                     scale_pct=r.get("scale_error_percent", float("nan")), fps=t["frames_per_second"],
                     frontend_ms=1000 * t["frontend_s"], backend_ms=1000 * t["backend_s"],
                     local_scale_min=local_scale_range(os.path.join(scratch, name))[0],
                     local_scale_max=local_scale_range(os.path.join(scratch, name))[1],
                     colmap_points=run.get("colmap", {}).get("points", 0),
                     colmap_error_px=run.get("colmap", {}).get("mean_reprojection_error_px", float("nan")),
                     colmap_export_s=t.get("colmap_export_s_total", 0.0),
                     loops=r.get("loops_accepted", 0),
                     # The odometry alone: trajectory_vo.tum's evaluation (eval_vo/).
                     ate_vo_m=vo.get("ate", {}).get("translation_m", {}).get("rmse", float("nan")),
                     scale_vo_pct=vo.get("scale", {}).get("scale_error_percent", float("nan")),
                     # Before the global BA (after the pose graph when loops were accepted).
                     ate_before_gba_m=gba.get("ate_rmse_m_before", float("nan")),
                     local_worst_before_gba_pct=gba.get("local_scale_worst_percent_before", float("nan")),
                     local_worst_pct=r.get("local_scale_worst_percent", float("nan")),
                     gba_s=t.get("global_ba_s_total", 0.0),
                     gba_share_pct=100 * t.get("global_ba_s_total", 0.0) / t["seconds_total"]))
with open("results/run_benchmark.csv", "w") as f:
    keys = list(rows[0].keys())
    f.write(",".join(keys) + "\n")
    for row in rows:
        f.write(",".join(str(row[k]) for k in keys) + "\n")
lines = ["# `mcvo run` on the synthetic urban route (tools/bench_run.sh)", "",
         "kitti360 rig, half resolution, 1575 frames at 10 Hz (1.18 km closed route, 7 corners), "
         "image noise 1 grey level. ATE: SE3 alignment (no scale fitted), rmse over the posed frames, "
         "as % of the ground-truth path over those frames. Scale error: 100 |1/s - 1| of the Sim3 fit. "
         "Local scale: min and max over 50-frame windows of estimated / true distance between the window's ends "
         "(how far the scale wanders along the route). "
         "fps: wall clock of the whole run on 2 cores (decoding + frontend + back end), not deterministic; "
         "writing the outputs afterwards is not in it (the COLMAP export's seconds are listed, with its points "
         "and mean reprojection error as `colmap model_analyzer` prints it).", "",
         "ATE, scale error and local scale of the final trajectory (after loop closure and the global BA); "
         "the odometry alone (trajectory_vo.tum) and the ATE before the global BA (after the pose graph where "
         "loops were accepted) in the last columns, with the global BA's time and its share of the run's "
         "(run.json timing). Local scale worst: the largest deviation from 1 over the 50-frame windows "
         "(docs/eval.md), after / before the global BA. "
         "loops: accepted loops (tools/bench_loop.sh has precision and recall). fps includes loop closure.", "",
         "| run | cameras | detector | frames (posed) | segments | path m | ATE m | ATE % | scale error % | local scale | local scale worst % after / before global BA | fps | frontend ms/frame | back end ms/frame | COLMAP points (error px, export s) | loops | odometry ATE m (%) | odometry scale error % | ATE m before global BA | global BA s (% of run) |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
for r in rows:
    lines.append(f"| {r['name']} | {r['cameras']} | {r['detector']} | {r['frames']} ({r['posed']}) | {r['segments']} | "
                 f"{r['path_m']:.1f} | {r['ate_m']:.3f} | {r['ate_pct']:.3f} | {r['scale_pct']:.3f} | "
                 f"{r['local_scale_min']:.3f}-{r['local_scale_max']:.3f} | "
                 f"{r['local_worst_pct']:.2f} / {r['local_worst_before_gba_pct']:.2f} | {r['fps']:.2f} | "
                 f"{r['frontend_ms']:.1f} | {r['backend_ms']:.1f} | "
                 f"{r['colmap_points']} ({r['colmap_error_px']:.2f}, {r['colmap_export_s']:.1f}) | {r['loops']} | "
                 f"{r['ate_vo_m']:.3f} ({100 * r['ate_vo_m'] / r['path_m'] if r['path_m'] else float('nan'):.3f}) | "
                 f"{r['scale_vo_pct']:.3f} | {r['ate_before_gba_m']:.3f} | {r['gba_s']:.1f} ({r['gba_share_pct']:.0f} %) |")
open("results/run_benchmark.md", "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
PY
