#!/usr/bin/env bash
# Far stereo points and the metric scale on real recordings (issue 56,
# item 5): what sets mcvo's scale on a real stereo pair, and what
# backend.cross_camera_min_angle_deg (with the initializer's two angles)
# does to it. Writes results/stereo_far_points.md and .csv.
#
#   tools/bench_stereo_far.sh [MCVO] [SCRATCH]
#       defaults: build/mcvo, ${TMPDIR:-/tmp}/mcvo_bench_stereo_far
#   env DATA   the real samples (default ../shared/data/real)
#
# 1. Where the scale comes from: every two-camera generic-layout sample with
#    groundtruth.tum (the KITTI stereo samples) is run with its rig.json's
#    camera-1 translation scaled by 0.99 and by 1.01 (a copy of the folder
#    in SCRATCH with the images linked); the Sim3 scale of `mcvo eval`
#    against the ground truth is compared with the unchanged rig. A change of
#    -1 % / +1 % says the stereo baseline sets the scale.
# 2. Are the disparities right: `mcvo track` of each such sample, then
#    tools/bench/stereo_disparity_check.py: every cross-camera match searched
#    again along the row by normalised SSD (independent of LK), by
#    disparity bin, and the mean vertical offset of the matches.
# 3. The angle: every sample of DATA (the monocular and the EuRoC ones
#    too, as a check that nothing else moves) with the built-in defaults
#    and with the three angles (backend.cross_camera_min_angle_deg,
#    initializer.min_cross_camera_angle_deg,
#    initializer.overlap_start.min_angle_deg) set to A, for A in ANGLES
#    (0 = the window BA keeps every match; the initializer's two at
#    max(A, 0.5), their value in 0.2.0). Scored as tools/bench_real.sh
#    scores: SE3 and Sim3 ATE % of the path, scale error %, or for a still
#    sample the ATE in mm and the estimate's path length.
# --threads 1 throughout (outputs are the same at any thread count).
set -euo pipefail
cd "$(dirname "$0")/.."
COMMAND_LINE="tools/bench_stereo_far.sh${*:+ $*}"
MCVO=${1:-build/mcvo}
SCRATCH=${2:-${TMPDIR:-/tmp}/mcvo_bench_stereo_far}
DATA=${DATA:-../shared/data/real}
ANGLES=${ANGLES:-"0 0.7 1.0 1.43 2.0"}
[[ -d $DATA ]] || { echo "bench_stereo_far.sh: no sample folder $DATA" >&2; exit 1; }
mkdir -p "$SCRATCH"
PY=/usr/bin/python3

gt_of() {
  for g in groundtruth.tum groundtruth_tum.txt; do [[ -f $1/$g ]] && { echo "$1/$g"; return; }; done
  echo -
}
evaluate() {  # gt traj name -> prints "se3_json sim3_json"
  for align in se3 sim3; do
    "$MCVO" eval --gt "$1" --est "$2" --align $align --force --out "$SCRATCH/eval_$3_$align" > /dev/null
  done
}

STEREO=()
for dir in "$DATA"/*/; do
  dir=${dir%/}
  [[ -f $dir/rig.json && -f $dir/groundtruth.tum ]] || continue
  n=$($PY -c "import json,sys; print(len(json.load(open(sys.argv[1]))['cameras']))" "$dir/rig.json")
  [[ $n == 2 ]] && STEREO+=("$dir")
done

: > "$SCRATCH/baseline.tsv"
: > "$SCRATCH/disparity.jsonl"
for dir in "${STEREO[@]}"; do
  sample=$(basename "$dir")
  for f in 1.00 0.99 1.01; do
    copy=$SCRATCH/baseline_${f}/$sample
    rm -rf "$copy"
    mkdir -p "$copy"
    for entry in "$dir"/*; do [[ $(basename "$entry") == rig.json ]] || ln -s "$(realpath "$entry")" "$copy/"; done
    $PY - "$dir/rig.json" "$copy/rig.json" "$f" <<'PY'
import json, sys
rig = json.load(open(sys.argv[1]))
t = rig["cameras"][1]["cam_from_rig"]["translation"]
rig["cameras"][1]["cam_from_rig"]["translation"] = [float(sys.argv[3]) * v for v in t]
json.dump(rig, open(sys.argv[2], "w"), indent=1)
PY
    out=$SCRATCH/run_baseline_${f}_$sample
    "$MCVO" run --dataset "$copy" --threads 1 --force --out "$out" > "$out.log" 2>&1
    evaluate "$dir/groundtruth.tum" "$out/trajectory.tum" "baseline_${f}_$sample"
    printf '%s\t%s\t%s\n' "$sample" "$f" "$SCRATCH/eval_baseline_${f}_${sample}_sim3/eval.json" >> "$SCRATCH/baseline.tsv"
    echo "$sample baseline x $f done" >&2
  done
  rm -f "$SCRATCH/$sample.trk.tmp"
  "$MCVO" track --dataset "$dir" --threads 1 --out "$SCRATCH/$sample.trk.tmp" > /dev/null 2>&1
  mv "$SCRATCH/$sample.trk.tmp" "$SCRATCH/$sample.trk"
  $PY tools/bench/stereo_disparity_check.py "$SCRATCH/$sample.trk" "$dir" | \
    $PY -c "import json,sys; d=json.load(sys.stdin); d['sample']=sys.argv[1]; print(json.dumps(d))" "$sample" \
    >> "$SCRATCH/disparity.jsonl"
done

: > "$SCRATCH/angles.tsv"
for dir in "$DATA"/*/; do
  dir=${dir%/}
  sample=$(basename "$dir")
  "$MCVO" info --dataset "$dir" > /dev/null 2>&1 || continue
  gt=$(gt_of "$dir")
  [[ $gt == - ]] && continue
  for angle in defaults $ANGLES; do
    args=()
    if [[ $angle != defaults ]]; then
      config=$SCRATCH/angle_$angle.json
      $PY - "$angle" "$config" <<'PY'
import json, sys
a = float(sys.argv[1])
json.dump({"backend": {"cross_camera_min_angle_deg": a},
           "initializer": {"min_cross_camera_angle_deg": max(a, 0.5),
                           "overlap_start": {"min_angle_deg": max(a, 0.5)}}}, open(sys.argv[2], "w"))
PY
      args=(--config "$config")
    fi
    out=$SCRATCH/run_angle_${angle}_$sample
    # exit 5: the run finished but posed no frame (its run.json says so)
    "$MCVO" run --dataset "$dir" "${args[@]}" --threads 1 --force --out "$out" > "$out.log" 2>&1 || [[ $? == 5 ]]
    posed=$($PY -c "import json,sys; print(json.load(open(sys.argv[1]))['result']['posed_frames'])" "$out/run.json")
    if [[ $posed == 0 ]]; then  # nothing to score: the row says so
      printf '%s\t%s\t%s\t%s\t%s\n' "$sample" "$angle" none "$out" - >> "$SCRATCH/angles.tsv"
      echo "$sample angle $angle: no frame posed" >&2
      continue
    fi
    evaluate "$gt" "$out/trajectory.tum" "angle_${angle}_$sample"
    scale=$($PY -c "import json,sys; print(json.load(open(sys.argv[1]))['result'].get('scale','metric'))" "$out/run.json")
    printf '%s\t%s\t%s\t%s\t%s\n' "$sample" "$angle" "$scale" "$out" "$SCRATCH/eval_angle_${angle}_$sample" >> "$SCRATCH/angles.tsv"
    echo "$sample angle $angle done" >&2
  done
done

$PY - "$SCRATCH" "$COMMAND_LINE" "$MCVO" > results/stereo_far_points.md <<'PY'
import csv, datetime, json, subprocess, sys
scratch, command_line, mcvo = sys.argv[1:]
commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
version = subprocess.run([mcvo, "version"], capture_output=True, text=True).stdout.split("\n")[0]
now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
print("# Far stereo points and the metric scale on real recordings\n")
print(f"`{command_line}`, {now}, {version}, commit {commit}. The script's header says what each part measures.\n")
print("## 1. The stereo baseline sets the scale\n")
print("| sample | rig baseline x | Sim3 scale of the estimate (est / truth) | change against x 1.00 |")
print("|---|---|---|---|")
base = {}
rows = [l.rstrip("\n").split("\t") for l in open(f"{scratch}/baseline.tsv")]
for sample, f, path in rows:
    s = json.load(open(path))["scale"]["est_scale_factor"]
    if f == "1.00":
        base[sample] = s
    change = 100 * (s / base[sample] - 1) if sample in base else 0.0
    print(f"| {sample} | {f} | {s:.4f} | {change:+.2f} % |")
print("\n## 2. The disparities agree with an independent search\n")
print("Normalised-SSD search along the row minus mcvo's disparity (px), by mcvo's disparity:\n")
print("| sample | matches compared | mean vertical offset y_b - y_a (px) | 0-5 px | 5-10 | 10-20 | 20-40 | 40+ |")
print("|---|---|---|---|---|---|---|---|")
for line in open(f"{scratch}/disparity.jsonl"):
    d = json.loads(line)
    cells = [f"{b['search_minus_mcvo_mean_px']:+.3f} (n {b['n']})" if b["n"] else "-" for b in d["bins"]]
    print(f"| {d['sample']} | {d['compared']} | {d['vertical_offset_px_mean']:+.3f} | " + " | ".join(cells) + " |")
print("\n## 3. backend.cross_camera_min_angle_deg on every real sample\n")
print("A = the window BA's angle and the initializer's two (those at max(A, 0.5)); defaults: the built-in config. "
      "ATE % of the ground-truth path; a still sample: ATE rmse in mm and the estimate's path in mm.\n")
print("| sample | A (deg) | SE3 ATE % | Sim3 ATE % | scale error % |")
print("|---|---|---|---|---|")
out_rows = []
for sample, angle, scale, run, ev in (l.rstrip("\n").split("\t") for l in open(f"{scratch}/angles.tsv")):
    if ev == "-":
        print(f"| {sample} | {angle} | no frame posed | - | - |")
        out_rows.append({"sample": sample, "angle": angle, "scale": "none posed"})
        continue
    se3 = json.load(open(f"{ev}_se3/eval.json"))
    sim3 = json.load(open(f"{ev}_sim3/eval.json"))
    path = se3["rpe"]["gt_path_length_m"]
    r = {"sample": sample, "angle": angle, "scale": scale}
    if path < 0.1:
        r.update(still=True, ate_mm=1000 * se3["ate"]["translation_m"]["rmse"],
                 est_path_mm=1000 * se3["start_end"]["est_path_length_m"])
        print(f"| {sample} | {angle} | {r['ate_mm']:.2f} mm | - | path {r['est_path_mm']:.1f} mm |")
    else:
        r.update(still=False, sim3_ate_percent=100 * sim3["ate"]["translation_m"]["rmse"] / path)
        metric = scale == "metric"
        r["se3_ate_percent"] = 100 * se3["ate"]["translation_m"]["rmse"] / path if metric else None
        r["scale_error_percent"] = se3["scale"]["scale_error_percent"] if metric else None
        f = lambda v, p: "arbitrary scale" if v is None else f"{v:.{p}f}"
        print(f"| {sample} | {angle} | {f(r['se3_ate_percent'], 3)} | {r['sim3_ate_percent']:.3f} | "
              f"{f(r['scale_error_percent'], 2)} |")
    out_rows.append(r)
keys = ["sample", "angle", "scale", "still", "se3_ate_percent", "sim3_ate_percent", "scale_error_percent", "ate_mm",
        "est_path_mm"]
with open("results/stereo_far_points.csv", "w", newline="") as fh:
    w = csv.DictWriter(fh, keys, extrasaction="ignore")
    w.writeheader()
    for r in out_rows:
        w.writerow({k: (f"{r[k]:.6g}" if isinstance(r.get(k), float) else r.get(k, "")) for k in keys})
PY
cat results/stereo_far_points.md
