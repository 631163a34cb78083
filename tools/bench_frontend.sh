#!/usr/bin/env bash
# Frontend benchmark of `mcvo track` on the kitti360 preset (4 cameras: two
# 1408x376 perspective, two 1400x1400 fisheyes) at full resolution. Writes
# results/frontend_benchmark.md (and prints it).
#
#   tools/bench_frontend.sh [FRAMES] [MCVO] [SCRATCH]
#       defaults: 30 frames, build/mcvo, ${TMPDIR:-/tmp}/mcvo_bench_frontend
#
# The sequence is rendered once into SCRATCH and reused by later runs with the
# same FRAMES (rendering at full resolution takes ~3 s per frame on 2 cores).
# Runs: every detector with the default selection (three_priority), then
# shi_tomasi with each selection method. Per-stage times come from
# `mcvo track --timing` (wall clock, NOT deterministic; docs/track-format.md):
#   stage columns  frames per second of that stage alone, its time summed over
#                  the 4 cameras (work per rig frame on one core);
#   decode wait    time the tracking thread waited for decoded images
#                  (FrameStream decodes PNGs ahead in THREADS background
#                  threads; near 0 when decoding keeps up);
#   track          wall time of MultiCameraTracker::Track (cameras in parallel);
#   total          whole-loop wall time per frame (decode wait + track + write).
# The superpoint model in ../shared/models has random weights: its row times
# the network interface only; its tracking numbers mean nothing.
set -euo pipefail
cd "$(dirname "$0")/.."
FRAMES=${1:-30}
MCVO=${2:-build/mcvo}
SCRATCH=${3:-${TMPDIR:-/tmp}/mcvo_bench_frontend}
THREADS=${THREADS:-2}
MODELS=../shared/models
OUT=results/frontend_benchmark.md
SEQ="$SCRATCH/kitti360-$FRAMES"

mkdir -p "$SCRATCH"
if [[ ! -f "$SEQ/frames.csv" ]]; then
  echo "rendering $FRAMES frames of the kitti360 preset at full resolution into $SEQ ..." >&2
  "$MCVO" synth --preset kitti360 --frames "$FRAMES" --threads "$THREADS" --force --out "$SEQ" >&2
fi

run() {  # name, extra flags...
  local name=$1
  shift
  "$MCVO" track --dataset "$SEQ" --threads "$THREADS" --out "$SCRATCH/$name.bin" --stats "$SCRATCH/$name.csv" \
    --timing "$SCRATCH/$name.json" "$@" >&2
}

run shi_tomasi --detector shi_tomasi --selection three_priority
run orb --detector orb
run xfeat --detector xfeat --model "$MODELS/xfeat_480x640.onnx"
run superpoint --detector superpoint --model "$MODELS/superpoint_layout_random_weights_480x640.onnx"
run shi_tomasi-quadtree --detector shi_tomasi --selection quadtree
run shi_tomasi-score --detector shi_tomasi --selection score

cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
python3 - "$SCRATCH" "$FRAMES" "$THREADS" "$cpu" "$(git rev-parse --short HEAD 2>/dev/null || echo unknown)" \
  > "$SCRATCH/table.md" <<'EOF'
import json, sys, datetime
scratch, frames, threads, cpu, commit = sys.argv[1:6]
def load(name):
    with open(f"{scratch}/{name}.json") as f:
        return json.load(f)
def fps(s):
    return f"{1.0 / s:.1f}" if s > 0 else "-"
print("# mcvo track frontend benchmark\n")
print(f"{datetime.date.today()}, commit {commit}, {threads} threads on {cpu}.")
print(f"kitti360 preset (synthetic, `mcvo synth`), {frames} frames at full resolution, 4 cameras per frame.")
print("Produced by `tools/bench_frontend.sh`; timings are wall clock and vary run to run.\n")
print("## Frames per second per stage (default selection: three_priority)\n")
print("Stage columns: 1 / (seconds of the stage per rig frame, summed over the 4 cameras).")
print("Decode: 1 / time the tracker waited for decoded images (PNG decoding runs ahead in")
print(f"{threads} background threads, so this is the part of decoding not hidden behind tracking).")
print("Track: MultiCameraTracker::Track wall time (cameras in parallel). Total: whole loop.\n")
print("| detector | decode wait | CLAHE | pyramid | LK | detection | RANSAC | selection | track | total |")
print("|---|---|---|---|---|---|---|---|---|---|")
for name, label in [("shi_tomasi", "shi_tomasi"), ("orb", "orb"), ("xfeat", "xfeat"),
                    ("superpoint", "superpoint (random weights: interface timing only)")]:
    s = load(name)["seconds_per_frame"]
    print(f"| {label} | {fps(s['decode_wait'])} | {fps(s.get('clahe', 0))} | {fps(s['pyramid'])} | {fps(s['lk'])} | "
          f"{fps(s['detection'])} | {fps(s['ransac'])} | {fps(s['selection'])} | {fps(s['track_wall'])} | "
          f"{fps(s['total'])} |")
print("\n## Tracking quality\n")
print("Mean track length: mean over all feature tracks of the frames each was seen in (tracks still")
print("alive at the last frame count as they are, so short sequences cap it). Inlier ratio: RANSAC")
print("inliers / (inliers + outliers) over all frames and cameras. SFD: the paper's spatial feature")
print("distribution (variance of feature counts over an 8x8 grid; lower is more uniform), mean over")
print("camera images.\n")
print("| detector | selection | tracks | mean track length [frames] | inlier ratio | mean SFD |")
print("|---|---|---|---|---|---|")
for name in ["shi_tomasi", "orb", "xfeat", "superpoint", "shi_tomasi-quadtree", "shi_tomasi-score"]:
    t = load(name)
    q = t["quality"]
    label = t["detector"] + (" (random weights)" if t["detector"] == "superpoint" else "")
    print(f"| {label} | {t['selection']} | {q['tracks']} | {q['mean_track_length']:.2f} | "
          f"{q['inlier_ratio']:.4f} | {q['mean_sfd']:.3f} |")
EOF
mkdir -p results
cp "$SCRATCH/table.md" "$OUT"
cat "$OUT"
