#!/usr/bin/env bash
# Real-data benchmark (issue 56, item 3): `mcvo run` on every recorded sample
# under ../shared/data/real (KITTI, EuRoC: real rigs, not renders), beside the
# trajectories other systems produced from the same frames (each sample's
# peers/*.tum), all scored by `mcvo eval` in the same way. Writes
# results/real.md and results/real.csv and prints the table.
#
#   tools/bench_real.sh [MCVO] [SCRATCH]
#       defaults: build/mcvo, ${TMPDIR:-/tmp}/mcvo_bench_real
#   env DATA   the samples' folder (default ../shared/data/real)
#
# Samples: every folder of DATA that `mcvo info --dataset` reads (a generic
# layout, rig.json + frames.csv, or EuRoC's mav0/), so a sample added later
# joins; a folder it does not read is listed as skipped. Ground truth: the
# folder's groundtruth.tum, else groundtruth_tum.txt, else EuRoC's
# mav0/state_groundtruth_estimate0/data.csv.
#
# Configs, per sample: the built-in defaults (no --config) and the rig's
# preset: the config/*.json whose dataset.cameras names exactly the rig's
# cameras (config/kitti360_2cam.json for the KITTI stereo pair image_00,
# image_01; config/euroc_stereo.json for EuRoC's cam0, cam1); a one-camera
# rig has no preset of its own and gets config/synthetic.json, the config
# the project's monocular suite runs (SUITE=monocular tools/bench_suite.sh).
# Each at --threads 2 and --threads 1: CPU seconds are the user + system
# seconds of the `mcvo run` command alone (tools/bench_common.sh seconds_of),
# start-up, outputs and evaluation included, over the sample's frames; the
# two trajectory.tum files are compared byte for byte (mcvo promises the
# same outputs at any thread count).
#
# Scoring, for mcvo's trajectory.tum (world_from_rig) and every peers/*.tum
# alike: `mcvo eval --gt GT --est TRAJ --align se3` and `--align sim3` (time
# association, 10 ms), read from eval.json: SE3 ATE % = 100 ate.translation_m.rmse
# / rpe.gt_path_length_m (the matched ground-truth path); Sim3 ATE % the same
# after the Sim3 fit; scale error % = scale.scale_error_percent = 100 |1/s - 1|;
# RPE rotation = 100 rpe.average.rotation_deg_per_m (deg per 100 m, mean over
# the segment lengths 10-50 % of the path; rotation RMSE after an SE3 fit is
# not meaningful on a nearly straight road). The peers are of camera 0, and on
# these samples camera 0 is the rig frame (identity in rig.json).
# A one-camera run has an arbitrary scale: no SE3 ATE nor scale error.
# A sample whose ground truth moves less than 0.1 m (standing still) has no
# path to take a percentage of: its ATE is in mm and the estimate's own path
# length (start_end.est_path_length_m, all poses) is reported.
# Peers' CPU seconds are not in their files; the table quotes the README's.
set -euo pipefail
cd "$(dirname "$0")/.."
COMMAND_LINE="tools/bench_real.sh${*:+ $*}"
MCVO=${1:-build/mcvo}
SCRATCH=${2:-${TMPDIR:-/tmp}/mcvo_bench_real}
DATA=${DATA:-../shared/data/real}
OUT_MD=results/real.md
OUT_CSV=results/real.csv
mkdir -p "$SCRATCH"
[[ -d $DATA ]] || { echo "bench_real.sh: no sample folder $DATA" >&2; exit 1; }

# shellcheck source=tools/bench_common.sh
source tools/bench_common.sh  # seconds_of

LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg)
RUNS="$SCRATCH/runs.tsv"   # sample format frames gt config threads run_dir wall cpu
SKIPPED="$SCRATCH/skipped.tsv"
: > "$RUNS"
: > "$SKIPPED"

preset_of() {  # info output file -> config path or empty
  python3 - "$1" <<'PY'
import glob, json, re, sys
names = re.findall(r"^camera \d+: (\S+)$", open(sys.argv[1]).read(), re.M)
for path in sorted(glob.glob("config/*.json")):
    if path.endswith("/default.json"):
        continue
    cams = json.load(open(path)).get("dataset", {}).get("cameras")
    if isinstance(cams, list) and cams == names:
        print(path)
        sys.exit(0)
if len(names) == 1:
    print("config/synthetic.json")
PY
}

for dir in "$DATA"/*/; do
  dir=${dir%/}
  sample=$(basename "$dir")
  info="$SCRATCH/info_$sample.txt"
  if ! "$MCVO" info --dataset "$dir" > "$info" 2>&1; then
    printf '%s\t%s\n' "$sample" "$(grep -m1 . "$info" | tr '\t' ' ')" >> "$SKIPPED"
    continue
  fi
  format=$(awk '$1 == "format" {print $2; exit}' "$info")
  frames=$(awk '$1 == "frames" {print $2; exit}' "$info" | tr -d ,)
  gt=-
  for g in groundtruth.tum groundtruth_tum.txt mav0/state_groundtruth_estimate0/data.csv; do
    [[ -f $dir/$g ]] && { gt=$dir/$g; break; }
  done
  find "$dir" -type f -exec cat {} + > /dev/null  # page cache: no row pays for the disk
  preset=$(preset_of "$info")
  for config in default ${preset:+"$preset"}; do
    label=$(basename "$config" .json)
    args=()
    [[ $config != default ]] && args=(--config "$config")
    for threads in 2 1; do
      out="$SCRATCH/run_${sample}_${label}_t$threads"
      t=$(seconds_of "$MCVO" run --dataset "$dir" "${args[@]}" --threads "$threads" --force --out "$out")
      printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$sample" "$format" "$frames" "$gt" "$config" "$threads" \
        "$out" ${t} >> "$RUNS"
      echo "$sample $label --threads $threads: $t (wall, cpu s)" >&2
    done
  done
done
LOAD_AFTER=$(cut -d' ' -f1-3 /proc/loadavg)

python3 - "$MCVO" "$DATA" "$SCRATCH" "$OUT_CSV" "$COMMAND_LINE" "$LOAD_BEFORE" "$LOAD_AFTER" > "$OUT_MD" <<'PY'
import csv, datetime, filecmp, glob, json, os, re, subprocess, sys
mcvo, data, scratch, out_csv, command_line, load_before, load_after = sys.argv[1:]
STILL_M = 0.1  # a ground truth that moves less than this stands still

def evaluate(gt, est, align, name):
    out = os.path.join(scratch, "eval", f"{name}_{align}")
    subprocess.run([mcvo, "eval", "--gt", gt, "--est", est, "--align", align, "--out", out, "--force"],
                   check=True, stdout=subprocess.DEVNULL)
    return json.load(open(os.path.join(out, "eval.json")))

def has_orientation(path):  # False when every pose's rotation is the identity (positions only)
    for line in open(path):
        f = line.split()
        if len(f) == 8 and not line.startswith("#") and [float(x) for x in f[4:7]] != [0.0, 0.0, 0.0]:
            return True
    return False

def readme_peers():  # (sample, first word of system, lowercased) -> row of the README's peer table
    rows = {}
    path = os.path.join(data, "README.md")
    if not os.path.exists(path):
        return rows
    for line in open(path):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 6 and not cells[0].startswith(("sample", "---")):
            rows[(cells[0], re.sub(r"[^a-z0-9]", "", cells[1].split()[0].lower()))] = cells
    return rows

def score(gt, est, name, scale_metric):
    row = {}
    se3, sim3 = evaluate(gt, est, "se3", name), evaluate(gt, est, "sim3", name)
    path = se3["rpe"]["gt_path_length_m"]
    still = path < STILL_M
    row["matched"] = se3["association"]["matched"]
    row["gt_path_m"] = path
    row["still"] = still
    row["est_path_m"] = se3["start_end"]["est_path_length_m"]
    row["se3_ate_m"] = se3["ate"]["translation_m"]["rmse"] if scale_metric else None
    row["sim3_ate_m"] = sim3["ate"]["translation_m"]["rmse"]
    row["se3_ate_percent"] = 100 * row["se3_ate_m"] / path if scale_metric and not still else None
    row["sim3_ate_percent"] = 100 * row["sim3_ate_m"] / path if not still else None
    row["scale_error_percent"] = se3["scale"]["scale_error_percent"] if scale_metric and not still else None
    rpe = se3["rpe"]["average"] if se3["rpe"]["computed"] else None
    orient = has_orientation(est)
    row["rpe_rot_deg_per_100m"] = 100 * rpe["rotation_deg_per_m"] if rpe and orient and not still else None
    row["rpe_rot_deg"] = rpe["rotation_deg"] if rpe and orient else None
    row["orientation"] = orient
    # Frame to frame: the metric step error for a metric run (se3 keeps relative motions), the
    # Sim3-scaled one for an arbitrary-scale run.
    step = (se3 if scale_metric else sim3)["rpe"]["step"]["translation_m"]
    row["rpe_step_mm"] = 1000 * step["rmse"] if step["count"] > 0 else None
    return row

runs = [r.rstrip("\n").split("\t") for r in open(os.path.join(scratch, "runs.tsv"))]
rows, peers_readme = [], readme_peers()
by_run = {}
for sample, fmt, frames, gt, config, threads, run_dir, wall, cpu in runs:
    by_run.setdefault((sample, config), {})[threads] = (run_dir, float(wall), float(cpu), int(frames), fmt, gt)
samples = list(dict.fromkeys(r[0] for r in runs))
for sample in samples:
    configs = [c for (s, c) in by_run if s == sample]
    gt = next(iter(by_run[(sample, configs[0])].values()))[5]
    for config in configs:
        t = by_run[(sample, config)]
        run_dir, wall2, cpu2, frames, fmt, _ = t["2"]
        result = json.load(open(os.path.join(run_dir, "run.json")))["result"]
        traj = os.path.join(run_dir, "trajectory.tum")
        row = {"sample": sample, "format": fmt, "frames": frames, "system": "mcvo",
               "config": "defaults" if config == "default" else config,
               "scale": result.get("scale", "metric"), "posed": result["posed_frames"],
               "cpu_s_per_frame_t2": cpu2 / frames, "cpu_s_per_frame_t1": t["1"][2] / frames,
               "wall_s_t2": wall2, "wall_s_t1": t["1"][1],
               "threads_identical": filecmp.cmp(traj, os.path.join(t["1"][0], "trajectory.tum"), shallow=False),
               "cpu_source": "measured"}
        if gt != "-":
            row.update(score(gt, traj, f"{sample}_{os.path.basename(config)}", row["scale"] == "metric"))
        rows.append(row)
    for peer in sorted(glob.glob(os.path.join(data, sample, "peers", "*.tum"))):
        system = os.path.basename(peer)[:-4]
        row = {"sample": sample, "format": "-", "frames": frames, "system": system, "config": "(stored trajectory)",
               "scale": "metric", "posed": sum(1 for l in open(peer) if l.strip() and not l.startswith("#")),
               "cpu_source": "README"}
        readme = peers_readme.get((sample, re.sub(r"[^a-z0-9]", "", system.split("_")[0].lower())))
        row["readme_cpu"] = readme[5] if readme else "-"
        row["readme_se3_ate_percent"] = readme[2] if readme else "-"
        if gt != "-":
            row.update(score(gt, peer, f"{sample}_peer_{system}", True))
        rows.append(row)

keys = ["sample", "system", "config", "frames", "posed", "matched", "scale", "gt_path_m", "est_path_m",
        "se3_ate_m", "se3_ate_percent", "sim3_ate_m", "sim3_ate_percent", "scale_error_percent",
        "rpe_rot_deg_per_100m", "rpe_rot_deg", "rpe_step_mm", "cpu_s_per_frame_t2", "cpu_s_per_frame_t1", "wall_s_t2",
        "wall_s_t1", "threads_identical", "readme_cpu", "readme_se3_ate_percent"]
def cell(v):
    if v is None: return ""
    if isinstance(v, bool): return "yes" if v else "no"
    if isinstance(v, float): return f"{v:.6g}"
    return str(v)
with open(out_csv, "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(keys)
    for r in rows:
        w.writerow([cell(r.get(k)) for k in keys])

commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", "src", "include", "tools",
                        "config", "CMakeLists.txt"], capture_output=True, text=True).stdout.strip()
version = subprocess.run([mcvo, "version"], capture_output=True, text=True).stdout.split("\n")[0].strip()
model = subprocess.run(["sh", "-c", "grep -m1 'model name' /proc/cpuinfo | cut -d: -f2"], capture_output=True,
                       text=True).stdout.strip()
now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
print("# Real data: `mcvo run` on recorded KITTI and EuRoC samples, beside other systems\n")
print(f"`{command_line}`\n")
print(f"{now}, {version}, commit {commit}{' (with uncommitted changes to the sources)' if dirty else ''}. "
      f"Machine: {os.cpu_count()} cores ({model}), shared: other engineers' builds and tests ran at the same "
      f"time (load average {load_before} before, {load_after} after), so CPU seconds are the honest measure "
      "and wall seconds (in the CSV) are not. CPU s per frame: user + system seconds of the `mcvo run` "
      "command only (all its threads; start-up, outputs, its own evaluation and report included) over the "
      "sample's frames, at --threads 2 / --threads 1.\n")
print(f"Samples: every folder of `{data}` that `mcvo info --dataset` reads (README.md there: what each is, "
      "its licence, how the peers were run). Configs: the built-in defaults (no --config) and the rig's "
      "preset (the config/*.json naming exactly the rig's cameras; config/synthetic.json, the monocular "
      "suite's, for a one-camera rig).\n")
print("Scoring, the same for every trajectory (mcvo's `trajectory.tum`, world_from_rig; each "
      "`peers/*.tum`, camera 0 = the rig frame on these samples): `mcvo eval --gt GT --est TRAJ --align se3` "
      "and `--align sim3`, time association within 10 ms. ATE % = rmse / the matched ground-truth path. "
      "Scale error = 100 |1/s - 1| of the Sim3 fit (the estimate's size against the truth). RPE rotation: "
      "deg per 100 m, the mean over segments of 10-50 % of the path (eval's rpe.average), not a rotation "
      "RMSE after a fit (not meaningful on a nearly straight road). RPE step: the translation rmse of the "
      "error between consecutive frames (eval's rpe.step; of the Sim3 fit for an arbitrary scale), in mm: "
      "what a pose that jumps relative to its neighbours costs.\n")
print("| sample | system | config | posed / frames | SE3 ATE % | Sim3 ATE % | scale error % | "
      "RPE rotation deg/100 m | RPE step mm | CPU s/frame (t2 / t1) | t1 = t2 |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
def pct(v, d=3): return "-" if v is None else f"{v:.{d}f}"
notes = set()
for r in rows:
    if "matched" not in r:
        se3 = sim3 = se = rot = step = "no ground truth"
    elif r["still"]:
        se3 = f"{1000 * r['se3_ate_m']:.2f} mm" if r["se3_ate_m"] is not None else "-"
        sim3 = f"{1000 * r['sim3_ate_m']:.2f} mm"
        se = f"path {1000 * r['est_path_m']:.1f} mm"
        rot = f"{r['rpe_rot_deg']:.3f} deg" if r["rpe_rot_deg"] is not None else "-"
        notes.add("still")
    else:
        se3, sim3 = pct(r["se3_ate_percent"]), pct(r["sim3_ate_percent"])
        se, rot = pct(r["scale_error_percent"], 2), pct(r["rpe_rot_deg_per_100m"], 2)
        if r["scale"] != "metric":
            se3 = se = "arbitrary scale"
        if not r["orientation"]:
            rot = "positions only"
    if "matched" in r:
        step = pct(r["rpe_step_mm"], 1)
    if r["cpu_source"] == "measured":
        cpu = f"{r['cpu_s_per_frame_t2']:.3f} / {r['cpu_s_per_frame_t1']:.3f}"
        same = "yes" if r["threads_identical"] else "**NO**"
    else:
        cpu, same = f"{r['readme_cpu']} (README)", "-"
    posed = f"{r['posed']} / {r['frames']}"
    if "matched" in r and r["matched"] < r["posed"]:
        posed += f" ({r['matched']} with gt)"
        notes.add("matched")
    print(f"| {r['sample']} | {r['system']} | {r['config']} | {posed} | {se3} | {sim3} | {se} | {rot} | {step} | {cpu} | {same} |")
print()
skipped = [l.rstrip("\n").split("\t") for l in open(os.path.join(scratch, "skipped.tsv"))]
for name, why in skipped:
    print(f"Skipped `{name}`: `mcvo info --dataset` does not read it ({why}).\n")
if "still" in notes:
    print(f"A sample whose ground truth moves less than {STILL_M} m stands still: no path to take a percentage "
          "of. Its ATE columns are the rmse in mm, the scale error column the estimate's own path length over "
          "all its poses (it should be under 1 cm), the RPE column the mean rotation error in degrees over the "
          "segments (10-50 % of the frames).\n")
if "matched" in notes:
    print("(N with gt): only N of the posed frames have a ground-truth pose within 10 ms; the scores are over "
          "those (euroc_v101_static: its ground truth starts 1.04 s after the first image).\n")
print("positions only: the stored trajectory's orientations are all the identity (the README: COLMAP's "
      "positions only), so it has no rotation to score. arbitrary scale: a one-camera run (metres unknown; "
      "its evaluation is the Sim3 one). Peers' CPU seconds are the README's (the owners' runs, not measured "
      "here). t1 = t2: mcvo's trajectory.tum at --threads 1 and 2 byte for byte.\n")
# Where mcvo (its defaults) stands against the peers of the same sample, metric by metric.
METRICS = [("se3_ate_percent", "SE3 ATE"), ("sim3_ate_percent", "Sim3 ATE"), ("scale_error_percent", "scale error"),
           ("rpe_rot_deg_per_100m", "RPE rotation"), ("rpe_step_mm", "RPE step mm")]
lines = []
for sample in samples:
    mine = next((r for r in rows if r["sample"] == sample and r["system"] == "mcvo" and r["config"] == "defaults"), None)
    peers = [r for r in rows if r["sample"] == sample and r["system"] != "mcvo" and "matched" in r]
    if not mine or not peers or "matched" not in mine:
        continue
    parts = []
    for key, label in METRICS:
        if mine.get(key) is None:
            continue
        better = [f"{p['system']} {p[key]:.3g}" for p in peers if p.get(key) is not None and p[key] < mine[key]]
        parts.append(f"{label} {mine[key]:.3g}: " + (f"worse than {', '.join(better)}" if better else "best"))
    lines.append(f"* {sample}: " + "; ".join(parts) + ".")
if lines:
    print("Where mcvo (defaults) stands against the peers on the same frames (lower is better):\n")
    print("\n".join(lines) + "\n")
same_as_defaults = []
for (sample, config), t in by_run.items():
    if config != "default":
        a = os.path.join(by_run[(sample, "default")]["2"][0], "trajectory.tum")
        same = filecmp.cmp(a, os.path.join(t["2"][0], "trajectory.tum"), shallow=False)
        same_as_defaults.append(f"{sample} {config}: {'identical' if same else 'different'}")
if same_as_defaults:
    print("The preset's trajectory against the defaults' (byte for byte): " + "; ".join(same_as_defaults) + ".\n")
print(f"CSV: `{out_csv}` (the numbers above to 6 significant digits, ATE in metres too, wall seconds).")
PY
cat "$OUT_MD"
