#!/usr/bin/env bash
# Real recordings against `mcvo synth` renders of the same rigs
# (results/render_realism.md): renders the sequences below (cached), runs
# mcvo_bench_image_stats on them and on the real samples of ../shared/data/real,
# and prints the comparison tables (tools/render_realism_table.py).
#
#   tools/bench_render_realism.sh [BUILD] [SCRATCH]
#       defaults: build, ${TMPDIR:-/tmp}/mcvo_render_realism
#   env FRAMES  frames per render (default 16), at 0.8 Hz (1.25 s apart: 16
#               frames span 19 s of the route, not 1.6 s of one street)
#
# Renders: the stereo preset (KITTI-360's rectified pair, 1408 x 376) on
# urban without effects and on urban, indoor and open with the suite's
# effects (--noise 2 --vignetting --motion-blur 3); the KITTI odometry rig
# of kitti06_stereo (1226 x 370, 0.537 m baseline; re-expressed in synth's
# rig frame, x forward, y right, z down, the cameras 1.65 m above the road)
# on urban with the suite's effects ("before") and with the realism flags at
# the values measured on KITTI ("after"); the suite's EuRoC-like pair
# (config/rigs/suite/roof_pair.json, EuRoC's radtan calibration) on indoor,
# without effects, before and after (values measured on the EuRoC sample).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
SCRATCH=${2:-${TMPDIR:-/tmp}/mcvo_render_realism}
FRAMES=${FRAMES:-16}
REAL=../shared/data/real
mkdir -p "$SCRATCH/seq" "$SCRATCH/stats"

# KITTI odometry rig in synth's rig frame.
python3 - "$REAL/kitti06_stereo/rig.json" "$SCRATCH/kitti_odometry_forward.json" <<'PY'
import json, sys
rig = json.load(open(sys.argv[1]))
out = {"description": "KITTI odometry grey stereo pair of kitti06_stereo (intrinsics, 1226 x 370, "
       "baseline 0.537 m), looking forward in synth's rig frame (x forward, y right, z down), "
       "cameras 1.65 m above the road (rig origin 1.5 m): tools/bench_render_realism.sh", "cameras": []}
for cam in rig["cameras"]:
    baseline = -cam["cam_from_rig"]["translation"][0]  # camera 1: +0.537 m to the right
    out["cameras"].append({"name": cam["name"], "model": cam["model"], "width": cam["width"],
                           "height": cam["height"], "params": cam["params"],
                           "rig_from_cam": {"rotation": [[0, 0, 1], [1, 0, 0], [0, 1, 0]],
                                            "translation": [0.0, baseline, -0.15]}})
json.dump(out, open(sys.argv[2], "w"), indent=2)
PY

SUITE="--noise 2 --vignetting --motion-blur 3"
# The realism flags at the values measured on the real samples (results/render_realism.md):
# noise a and b from the samples' lower-envelope fit; the lens blur that brings the render's
# measured edge blur (0.48 px without any flag, 0.7 with --motion-blur 3) to the sample's
# (KITTI 0.9 px, EuRoC 1.0 px); KITTI's tone curve fitted to kitti06's grey-level quantiles
# and share of clipped pixels from the render without effects. EuRoC gets no tone curve: its
# sample (a room with a bright window) and the indoor scene differ too much in content for a
# fit of grey levels to say anything about the camera.
KITTI_AFTER="--sensor-noise 0.033:0 --lens-blur 0.6 --tone 1.5:1.5 --motion-blur 3"
EUROC_AFTER="--sensor-noise 0.027:0 --lens-blur 0.9 --motion-blur 3"
render() {  # NAME ARGS...
  local name=$1; shift
  if [[ ! -f "$SCRATCH/seq/$name/frames.csv" ]]; then
    echo "rendering $name: $*" >&2
    "$BUILD/mcvo" synth "$@" --frames "$FRAMES" --rate 0.8 --threads 2 --force --out "$SCRATCH/seq/$name" >&2
  fi
  "$BUILD/mcvo_bench_image_stats" "$SCRATCH/seq/$name" > "$SCRATCH/stats/render_$name.json"
}
for sample in kitti06_stereo kitti01_stereo kitti00_mono euroc_v101_static; do
  "$BUILD/mcvo_bench_image_stats" "$REAL/$sample" > "$SCRATCH/stats/real_$sample.json"
done
"$BUILD/mcvo_bench_image_stats" "$REAL/euroc_v101_static" --temporal > "$SCRATCH/stats/real_euroc_temporal.json"
render stereo_urban_clean --preset stereo --image-scale 1
render stereo_urban_suite --preset stereo --image-scale 1 $SUITE
render stereo_indoor_suite --preset stereo --image-scale 1 --scene indoor $SUITE
render stereo_open_suite --preset stereo --image-scale 1 --scene open $SUITE
render kitti_urban_clean --rig "$SCRATCH/kitti_odometry_forward.json" --scene urban
render kitti_urban_suite --rig "$SCRATCH/kitti_odometry_forward.json" --scene urban $SUITE
render kitti_urban_after --rig "$SCRATCH/kitti_odometry_forward.json" --scene urban $KITTI_AFTER
render euroc_indoor_clean --rig config/rigs/suite/roof_pair.json --scene indoor
render euroc_indoor_suite --rig config/rigs/suite/roof_pair.json --scene indoor $SUITE
render euroc_indoor_after --rig config/rigs/suite/roof_pair.json --scene indoor $EUROC_AFTER
python3 tools/render_realism_table.py "$SCRATCH/stats"
