#!/usr/bin/env bash
# Loop-closure benchmark of `mcvo run` on the synthetic suite: loop precision
# and recall against the ground truth, ATE before and after loop closure, and
# the time per keyframe of feature extraction, database query and
# verification. Writes results/loop_benchmark.md and results/loop_benchmark.csv.
#
#   tools/bench_loop.sh [MCVO] [SCRATCH]
#       defaults: build/mcvo, ${TMPDIR:-/tmp}/mcvo_bench_loop
#
# Sequences (kitti360 rig, 4 cameras, config/kitti360_4cam.json):
#   urban        the 1.18 km closed route of tools/bench_run.sh (half
#                resolution; its 4cam run is reused from BENCH_RUN_SCRATCH
#                when there, else run here): one revisit, at the end;
#   urban_block  a short closed route around a block, driven BLOCK_LAPS laps
#                (0.35 image scale): the second lap revisits the first;
#   urban_repeated  every facade alike, a route that never returns (0.35
#                image scale): any accepted loop is false.
# Ground truth of a revisit: a query keyframe has a true place to close to
# when an earlier keyframe, outside the excluded recent keyframes, was within
# REVISIT_M metres; an accepted loop is correct when its two keyframes are
# within REVISIT_M metres in the ground truth. Precision: correct accepted
# loops over accepted loops; recall: query keyframes with a true place that
# got an accepted loop, over query keyframes with a true place.
set -euo pipefail
cd "$(dirname "$0")/.."
MCVO=${1:-build/mcvo}
SCRATCH=${2:-${TMPDIR:-/tmp}/mcvo_bench_loop}
BENCH_RUN_SCRATCH=${BENCH_RUN_SCRATCH:-${TMPDIR:-/tmp}/mcvo_bench_run}
REVISIT_M=${REVISIT_M:-10}
BLOCK_LAPS=${BLOCK_LAPS:-1.5}
mkdir -p "$SCRATCH" results

render() {  # name, scene, length ("--laps X" or "--frames N"; --frames 0: the whole route), scale
  if [[ ! -f "$SCRATCH/$1/frames.csv" ]]; then
    # shellcheck disable=SC2086
    "$MCVO" synth --preset kitti360 --scene "$2" $3 --image-scale "$4" --samples 1 --noise 1 \
      --seed 3 --out "$SCRATCH/$1" --force >&2
  fi
}
run() {  # name, dataset
  if [[ "${REUSE:-0}" == 1 && -f "$SCRATCH/run_$1/run.json" ]]; then return; fi
  "$MCVO" run --dataset "$2" --config config/kitti360_4cam.json --threads 2 --out "$SCRATCH/run_$1" --force >&2
}

# urban: the run benchmark's sequence and 4cam run.
URBAN_SEQ="$BENCH_RUN_SCRATCH/urban_kitti360_half"
if [[ -f "$BENCH_RUN_SCRATCH/4cam/loops.csv" ]]; then
  rm -rf "$SCRATCH/run_urban"
  cp -R "$BENCH_RUN_SCRATCH/4cam" "$SCRATCH/run_urban"
else
  if [[ ! -f "$URBAN_SEQ/frames.csv" ]]; then
    URBAN_SEQ="$SCRATCH/urban_kitti360_half"
    [[ -f "$URBAN_SEQ/frames.csv" ]] || "$MCVO" synth --preset kitti360 --image-scale 0.5 --noise 1 --seed 1 \
      --out "$URBAN_SEQ" --force >&2
  fi
  run urban "$URBAN_SEQ"
fi
render block urban_block "--laps $BLOCK_LAPS" 0.35
render repeated urban_repeated "--frames 0" 0.35
run block "$SCRATCH/block"
run repeated "$SCRATCH/repeated"

python3 - "$SCRATCH" "$URBAN_SEQ" "$REVISIT_M" <<'PY'
import csv, json, math, os, sys
scratch, urban_seq, revisit_m = sys.argv[1], sys.argv[2], float(sys.argv[3])


def frame_positions(seq):
    times = [int(row["t_ns"]) for row in csv.DictReader(open(os.path.join(seq, "frames.csv")))]
    gt = {}
    for line in open(os.path.join(seq, "groundtruth.tum")):
        if line.startswith("#") or not line.strip():
            continue
        v = line.split()
        gt[round(float(v[0]) * 1e9 / 1e6)] = tuple(map(float, v[1:4]))  # key: ms
    return [gt.get(round(t / 1e6)) for t in times]


rows = []
for name, seq in [("urban", urban_seq), ("urban_block", os.path.join(scratch, "block")),
                  ("urban_repeated", os.path.join(scratch, "repeated"))]:
    run_dir = os.path.join(scratch, "run_" + name.replace("urban_", "") if name != "urban" else "run_urban")
    run = json.load(open(os.path.join(run_dir, "run.json")))
    result, timing = run["result"], run["timing"]
    exclude = run["config"]["loop"]["exclude_recent_keyframes"]
    positions = frame_positions(seq)
    keyframes = []  # frame indices in keyframe order
    for line in open(os.path.join(run_dir, "keyframes.tum")):
        if line.startswith("#") or not line.strip():
            continue
        t_ms = round(float(line.split()[0]) * 1e3)
        keyframes.append(t_ms)
    times = [round(int(row["t_ns"]) / 1e6) for row in csv.DictReader(open(os.path.join(seq, "frames.csv")))]
    index_of = {t: i for i, t in enumerate(times)}
    kf_frames = [index_of[t] for t in keyframes]
    kf_pos = [positions[f] for f in kf_frames]
    has_place = []
    for q in range(len(kf_pos)):
        has_place.append(any(math.dist(kf_pos[q], kf_pos[k]) < revisit_m for k in range(0, q - exclude)))
    loops = list(csv.DictReader(open(os.path.join(run_dir, "loops.csv"))))
    accepted = [l for l in loops if l["accepted"] == "1"]
    correct = [l for l in accepted
               if math.dist(positions[int(l["query_frame"])], positions[int(l["candidate_frame"])]) < revisit_m]
    closed_queries = {int(l["query_keyframe"]) for l in correct}
    with_place = sum(has_place)
    recall_hits = sum(1 for q in closed_queries if q < len(has_place) and has_place[q])
    n_kf = max(1, len(kf_frames))
    rows.append(dict(
        sequence=name, frames=result["frames"], keyframes=len(kf_frames), path_m=result.get("gt_path_length_m", 0.0),
        keyframes_with_revisit=with_place, verified=sum(1 for l in loops if l["verified"] == "1"),
        accepted=len(accepted), correct=len(correct),
        precision=(len(correct) / len(accepted)) if accepted else float("nan"),
        recall=(recall_hits / with_place) if with_place else float("nan"),
        ate_before_m=result.get("ate_rmse_m_before_loop_closure", result.get("ate_rmse_m", float("nan"))),
        ate_after_m=result.get("ate_rmse_m", float("nan")),
        features_ms=1000 * timing.get("loop_features_s_per_keyframe", 0.0),
        query_ms=1000 * timing.get("loop_query_s_per_keyframe", 0.0),
        verification_ms=1000 * timing.get("loop_verification_s_per_keyframe", 0.0),
        image_read_ms=1000 * timing.get("loop_image_read_s_per_keyframe", 0.0),
        pose_graph_s=timing.get("pose_graph_s_total", 0.0)))

with open("results/loop_benchmark.csv", "w") as f:
    keys = list(rows[0].keys())
    f.write(",".join(keys) + "\n")
    for r in rows:
        f.write(",".join(str(r[k]) for k in keys) + "\n")


def fmt(x, spec):
    return "-" if isinstance(x, float) and math.isnan(x) else format(x, spec)


lines = ["# Loop closure on the synthetic suite (tools/bench_loop.sh)", "",
         f"kitti360 rig (4 cameras), config/kitti360_4cam.json, 2 cores. A keyframe has a true place to close to "
         f"when an earlier keyframe outside the excluded recent ones was within {revisit_m:g} m (ground truth); "
         f"an accepted loop is correct when its keyframes are within {revisit_m:g} m. Precision: correct / "
         f"accepted loops; recall: keyframes with a true place that got a correct loop / keyframes with a true "
         f"place (consecutive keyframes of one revisit each count). ATE: SE3 alignment, rmse, before and after "
         f"the pose graph. Times: per keyframe, wall clock, not deterministic.", "",
         "| sequence | frames | keyframes | path m | keyframes with a revisit | verified | accepted | correct | "
         "precision | recall | ATE before m | ATE after m | image read ms | features ms | query ms | "
         "verification ms | pose graph s |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
for r in rows:
    lines.append(f"| {r['sequence']} | {r['frames']} | {r['keyframes']} | {r['path_m']:.1f} | "
                 f"{r['keyframes_with_revisit']} | {r['verified']} | {r['accepted']} | {r['correct']} | "
                 f"{fmt(r['precision'], '.3f')} | {fmt(r['recall'], '.3f')} | {r['ate_before_m']:.3f} | "
                 f"{r['ate_after_m']:.3f} | {r['image_read_ms']:.1f} | {r['features_ms']:.1f} | "
                 f"{r['query_ms']:.2f} | {r['verification_ms']:.1f} | {r['pose_graph_s']:.3f} |")
open("results/loop_benchmark.md", "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
PY
