#!/usr/bin/env bash
# COLMAP's own programs on the COLMAP models of the suite's runs (issue 15's
# check of the refined model): does COLMAP agree with our poses?
#
#   tools/bench_colmap.sh [MCVO] [SUITE_SCRATCH] [WORK]
#       defaults: build/mcvo (its `eval` fits the similarity), ${TMPDIR:-/tmp}/mcvo_suite (tools/bench_suite.sh's scratch;
#       run the suite first), ${TMPDIR:-/tmp}/mcvo_bench_colmap
#   env RUNS   space-separated suite run names (SCRATCH/runs/<run>); default:
#              four runs of 318-723 images: kitti360 2 cameras, stereo, the
#              roof pair, the 3-camera rig (the SIFT matching of a 940-image
#              4-camera model takes over 15 min on 2 cores)
#
# Per run, on colmap/sparse/0 as `mcvo run` wrote it (keyframes, landmarks,
# the cameras' COLMAP models, images linked):
#   1. `colmap model_analyzer`: points, observations and the mean
#      reprojection error COLMAP computes with its own camera models;
#   2. `colmap bundle_adjuster` on our model, intrinsics fixed (COLMAP fixes
#      the first image's pose and one coordinate of the second's position):
#      its cost before and after, and how far each image's camera centre
#      moves, median and max, in cm;
#   3. SIFT features of the same images (`feature_extractor`, 1000 an image,
#      one camera per folder; `sequential_matcher` over 5 neighbours in name
#      order, so each camera's keyframes in turn), `point_triangulator` with our poses and
#      cameras fixed (clear_points: none of our points), then
#      `bundle_adjuster` on that model: independent features, COLMAP's own
#      triangulation and BA; its cost and how far the camera centres move.
# The moves are given raw (COLMAP's gauge) and after a similarity fitted to
# the centres (what no gauge choice changes). Which poses are right is
# decided by the truth: the ATE of the camera centres (the dataset's
# groundtruth.tum and rig.json) of ours, after COLMAP's BA and after the
# SIFT BA. COLMAP 3.8 knows no rig: its BA moves every image on its own.
# Writes results/colmap_check.md and .csv.
set -euo pipefail
cd "$(dirname "$0")/.."
MCVO=$(realpath "${1:-build/mcvo}")
SCRATCH=${2:-${TMPDIR:-/tmp}/mcvo_suite}
WORK=${3:-${TMPDIR:-/tmp}/mcvo_bench_colmap}
RUNS=${RUNS:-"k360_block_s3_expo.kitti360_2cam st_urban_s21_noise.kitti360_2cam roof_urban_s61.synthetic \
k3_block_s11.kitti360_3cam"}
export QT_QPA_PLATFORM=offscreen
command -v colmap >/dev/null || { echo "bench_colmap.sh: colmap is not on PATH (apt-get install colmap)" >&2; exit 2; }
mkdir -p "$WORK" results
TSV=$WORK/colmap_check.tsv
: > "$TSV"

centres_moved() {  # before_model after_model dataset out_dir -> 8 numbers (see below)
  # The camera centres of the images both models have, and the true ones
  # (the dataset's groundtruth.tum rig poses and rig.json extrinsics), as
  # TUM trajectories (time = index in name order). Prints: the raw move's
  # median and max (cm); after a similarity fitted by `mcvo eval --align
  # sim3`, median and max (cm); the ATE rmse (cm, SE3 alignment) against the
  # truth of before and of after.
  python3 - "$1" "$2" "$3" "$4" <<'PY'
import csv, json, math, os, sys


def rotation(qw, qx, qy, qz):
    return [[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
            [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
            [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]]


def centre(q_wxyz, t):  # C = -R^T t of a camera_from_world (or camera_from_rig) pose
    r = rotation(*q_wxyz)
    return tuple(-sum(r[k][i] * t[k] for k in range(3)) for i in range(3))


def centres(model):
    out, lines = {}, [l for l in open(model + "/images.txt") if not l.startswith("#")]
    for line in lines[0::2]:
        v = line.split()
        if len(v) >= 10:
            out[v[9]] = centre(tuple(map(float, v[1:5])), tuple(map(float, v[5:8])))
    return out


def true_centres(root, names):
    rig = json.load(open(os.path.join(root, "rig.json")))
    lever = {c["name"]: centre(c["cam_from_rig"]["quaternion_wxyz"], c["cam_from_rig"]["translation"])
             for c in rig["cameras"]}
    gt = [list(map(float, l.split())) for l in open(os.path.join(root, "groundtruth.tum"))
          if l.strip() and not l.startswith("#")]
    gt_by_ns = {round(v[0] * 1e9): v for v in gt}
    where = {}
    for row in csv.DictReader(open(os.path.join(root, "frames.csv"))):
        for cam, path in row.items():
            if cam != "t_ns" and path:
                where[path] = (cam, int(row["t_ns"]))
    out = {}
    for n in names:
        if n not in where or where[n][1] not in gt_by_ns:
            continue
        cam, t_ns = where[n]
        _, x, y, z, qx, qy, qz, qw = gt_by_ns[t_ns]
        r = rotation(qw, qx, qy, qz)
        out[n] = tuple((x, y, z)[i] + sum(r[i][k] * lever[cam][k] for k in range(3)) for i in range(3))
    return out


a, b, root, out = centres(sys.argv[1]), centres(sys.argv[2]), sys.argv[3], sys.argv[4]
names = sorted(set(a) & set(b))
truth = true_centres(root, names)
if len(truth) == len(names):
    trajectories = (("before", a), ("after", b), ("truth", truth))
else:
    trajectories = (("before", a), ("after", b))
os.makedirs(out, exist_ok=True)
for tag, c in trajectories:
    with open(os.path.join(out, tag + ".tum"), "w") as f:
        for i, n in enumerate(names):
            f.write(f"{i} {c[n][0]:.9f} {c[n][1]:.9f} {c[n][2]:.9f} 0 0 0 1\n")
raw = sorted(math.dist(a[n], b[n]) for n in names)
k = len(raw)
median = raw[k // 2] if k % 2 else 0.5 * (raw[k // 2 - 1] + raw[k // 2])
print(100 * median, 100 * raw[-1])
PY
  ate_cm() { python3 -c 'import json, sys; t = json.load(open(sys.argv[1]))["ate"]["translation_m"]; print(*(100 * t[k] for k in sys.argv[2:]))' "$@"; }
  "$MCVO" eval --gt "$4/before.tum" --est "$4/after.tum" --align sim3 --associate index --out "$4/moved" >/dev/null
  ate_cm "$4/moved/eval.json" median max
  if [[ -f "$4/truth.tum" ]]; then
    "$MCVO" eval --gt "$4/truth.tum" --est "$4/before.tum" --align se3 --associate index --out "$4/before_eval" >/dev/null
    "$MCVO" eval --gt "$4/truth.tum" --est "$4/after.tum" --align se3 --associate index --out "$4/after_eval" >/dev/null
    ate_cm "$4/before_eval/eval.json" rmse
    ate_cm "$4/after_eval/eval.json" rmse
  else
    echo nan
    echo nan
  fi
}

ba_costs() {  # bundle_adjuster log -> "initial final" (Ceres' cost as COLMAP prints it, px)
  sed -n 's/.*Initial cost : \([0-9.e+-]*\).*/\1/p; s/.*Final cost : \([0-9.e+-]*\).*/\1/p' "$1" | paste -sd' '
}

analyze() {  # model -> "points observations mean_error_px"
  colmap model_analyzer --path "$1" 2>&1 | python3 -c '
import re, sys
text = sys.stdin.read()
get = lambda k: (re.search(k + r": ([0-9.]+)", text) or [None, "nan"])[1]
print(get("Points"), get("Observations"), get("Mean reprojection error"))'
}

for run in $RUNS; do
  model=$SCRATCH/runs/$run/colmap/sparse/0
  images=$SCRATCH/runs/$run/colmap/images
  if [[ ! -f "$model/images.bin" ]]; then
    echo "bench_colmap.sh: $model has no images.bin (run tools/bench_suite.sh first); skipped" >&2
    continue
  fi
  w=$WORK/$run
  rm -rf "$w"
  mkdir -p "$w"/ours_txt "$w"/ba "$w"/ba_txt "$w"/tri "$w"/tri_ba "$w"/tri_ba_txt
  echo "== $run" >&2
  t0=$(date +%s)
  read -r points obs error < <(analyze "$model")
  colmap model_converter --input_path "$model" --output_path "$w/ours_txt" --output_type TXT >/dev/null 2>&1
  images_n=$(grep -vc '^#' "$w/ours_txt/images.txt" | awk '{ print $1 / 2 }')
  fixed="--BundleAdjustment.refine_focal_length 0 --BundleAdjustment.refine_principal_point 0 \
--BundleAdjustment.refine_extra_params 0"
  # shellcheck disable=SC2086
  colmap bundle_adjuster --input_path "$model" --output_path "$w/ba" $fixed >"$w/ba.log" 2>&1
  colmap model_converter --input_path "$w/ba" --output_path "$w/ba_txt" --output_type TXT >/dev/null 2>&1
  dataset=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["dataset"]["root"])' \
    "$SCRATCH/runs/$run/run.json")
  read -r ba_med ba_max ba_smed ba_smax ours_ate ba_ate < <(centres_moved "$w/ours_txt" "$w/ba_txt" "$dataset" \
    "$w/ba_moved" | paste -sd' ')
  read -r ba_initial ba_final < <(ba_costs "$w/ba.log")
  colmap feature_extractor --database_path "$w/db.db" --image_path "$images" \
    --ImageReader.single_camera_per_folder 1 --SiftExtraction.use_gpu 0 --SiftExtraction.num_threads 2 \
    --SiftExtraction.max_num_features 1000 >"$w/extract.log" 2>&1
  colmap sequential_matcher --database_path "$w/db.db" --SiftMatching.use_gpu 0 --SiftMatching.num_threads 2 \
    --SequentialMatching.overlap 5 --SequentialMatching.loop_detection 0 >"$w/match.log" 2>&1
  colmap point_triangulator --database_path "$w/db.db" --image_path "$images" --input_path "$model" \
    --output_path "$w/tri" --clear_points 1 --Mapper.num_threads 2 >"$w/tri.log" 2>&1
  read -r tri_points tri_obs tri_error < <(analyze "$w/tri")
  # shellcheck disable=SC2086
  colmap bundle_adjuster --input_path "$w/tri" --output_path "$w/tri_ba" $fixed >"$w/tri_ba.log" 2>&1
  colmap model_converter --input_path "$w/tri_ba" --output_path "$w/tri_ba_txt" --output_type TXT >/dev/null 2>&1
  read -r tri_med tri_max tri_smed tri_smax _ tri_ate < <(centres_moved "$w/ours_txt" "$w/tri_ba_txt" "$dataset" \
    "$w/tri_moved" | paste -sd' ')
  read -r tri_initial tri_final < <(ba_costs "$w/tri_ba.log")
  seconds=$(($(date +%s) - t0))
  printf '%s\t' "$run" "$images_n" "$points" "$obs" "$error" "$ba_initial" "$ba_final" "$ba_med" "$ba_max" \
    "$ba_smed" "$ba_smax" "$ours_ate" "$ba_ate" "$tri_points" "$tri_obs" "$tri_error" "$tri_initial" "$tri_final" \
    "$tri_med" "$tri_max" "$tri_smed" "$tri_smax" "$tri_ate" | sed 's/\t$//' >>"$TSV"
  echo >>"$TSV"
  echo "   $(tail -1 "$TSV") (${seconds} s)" >&2
done

COMMIT=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
# sed reads all of it: `head` closing the pipe early fails the pipeline under pipefail.
COLMAP_VERSION=$(colmap -h 2>&1 | sed -n '1s/ -- .*//p')
python3 - "$TSV" "$COMMIT" "$COLMAP_VERSION" "$SCRATCH" <<'PY'
import csv, sys
tsv, commit, version, scratch = sys.argv[1:]
keys = ["run", "images", "points", "observations", "error_px", "ba_initial_px", "ba_final_px", "ba_median_cm",
        "ba_max_cm", "ba_sim3_median_cm", "ba_sim3_max_cm", "ours_ate_cm", "ba_ate_cm", "sift_points",
        "sift_observations", "sift_error_px", "sift_ba_initial_px", "sift_ba_final_px", "sift_ba_median_cm",
        "sift_ba_max_cm", "sift_ba_sim3_median_cm", "sift_ba_sim3_max_cm", "sift_ba_ate_cm"]
rows = [dict(zip(keys, line)) for line in csv.reader(open(tsv), delimiter="\t") if line]
with open("results/colmap_check.csv", "w") as out:
    out.write(",".join(keys) + "\n")
    for r in rows:
        out.write(",".join(r.get(k, "") for k in keys) + "\n")


def f(x, d=2):
    try:
        return f"{float(x):.{d}f}"
    except (TypeError, ValueError):
        return "-"


lines = ["# COLMAP's programs on mcvo's COLMAP models (tools/bench_colmap.sh)", "",
         f"{version}; this table written at mcvo commit {commit} from the models of the suite's runs in {scratch}/runs "
         "(tools/bench_suite.sh; results/suite.md names the commit that ran them: 300 frames each, after the global "
         "BA).", "",
         "- error: mean reprojection error of our model as `colmap model_analyzer` computes it with COLMAP's camera "
         "models.",
         "- COLMAP BA: `colmap bundle_adjuster` on our model (our points and observations), intrinsics fixed; its "
         "cost before and after (Ceres' cost as COLMAP prints it, px); how far the camera centres moved (cm, median / "
         "max over the images; raw in COLMAP's gauge, which fixes the first image and one coordinate of the second; "
         "and after a similarity fitted to the centres).",
         "- ATE: rmse (cm) of the camera centres against the true ones (the dataset's ground truth and rig "
         "extrinsics), SE3 alignment: ours, after COLMAP's BA, after SIFT + COLMAP's BA.",
         "- SIFT: COLMAP's own features (`feature_extractor`, `sequential_matcher`, 5 neighbours, 1000 features an image), "
         "`point_triangulator` with our poses and cameras (points cleared), its mean reprojection error; then "
         "`bundle_adjuster` on that model: cost before / after, centre moves, ATE.",
         "COLMAP 3.8 has no rig: its BA moves every image on its own (the cameras of one frame too), so the scale "
         "along the route is held only by the chain of images, as in monocular SfM.", "",
         "| run | images | points | error px | COLMAP BA cost px | moved cm raw | moved cm after Sim3 | ATE cm ours | "
         "ATE cm after COLMAP BA | SIFT points (obs) | SIFT error px | SIFT BA cost px | SIFT BA moved cm after Sim3 | "
         "ATE cm after SIFT BA |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
for r in rows:
    lines.append(f"| {r['run']} | {r['images']} | {r['points']} | {f(r['error_px'], 3)} | "
                 f"{f(r['ba_initial_px'], 4)} -> {f(r['ba_final_px'], 4)} | {f(r['ba_median_cm'])} / {f(r['ba_max_cm'])} | "
                 f"{f(r['ba_sim3_median_cm'])} / {f(r['ba_sim3_max_cm'])} | {f(r['ours_ate_cm'])} | {f(r['ba_ate_cm'])} | "
                 f"{r['sift_points']} ({r['sift_observations']}) | {f(r['sift_error_px'], 3)} | "
                 f"{f(r['sift_ba_initial_px'], 4)} -> {f(r['sift_ba_final_px'], 4)} | "
                 f"{f(r['sift_ba_sim3_median_cm'])} / {f(r['sift_ba_sim3_max_cm'])} | {f(r['sift_ba_ate_cm'])} |")
open("results/colmap_check.md", "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
PY
