#!/usr/bin/env python3
"""A/B table of two robustness-suite runs (tools/bench_suite.sh) with the
frame-to-frame error beside the suite's own columns.

  tools/suite_ab_step.py MCVO A_CSV A_RUNS B_CSV B_RUNS

A_CSV, B_CSV: the suite tables (OUT_BASE.csv) of the two binaries or
settings; A_RUNS, B_RUNS: their run folders (SCRATCH/runs). For every run of
A_CSV (sequence.config) both trajectories are scored with `MCVO eval` against
the sequence's groundtruth.tum (SE3; Sim3 for a one-camera rig, whose scale
is arbitrary), into a temporary folder that is removed afterwards. Prints a
Markdown table (ATE %, scale error % from the CSVs; RPE step rmse in mm from
eval's rpe.step) and the medians, worsts and counts of runs that got better.
"""
import csv, json, os, statistics, subprocess, sys, tempfile

def table(path):
    return {(r["sequence"], r["config"]): r for r in csv.DictReader(open(path))}

def number(row, key):
    try:
        return float(row[key])
    except (KeyError, ValueError):
        return None

def step_mm(mcvo, run, one_camera, scratch):
    run_json = json.load(open(os.path.join(run, "run.json")))
    gt = os.path.join(run_json["dataset"]["root"], "groundtruth.tum")
    out = os.path.join(scratch, "eval")
    subprocess.run([mcvo, "eval", "--gt", gt, "--est", os.path.join(run, "trajectory.tum"), "--align",
                    "sim3" if one_camera else "se3", "--out", out, "--force"], check=True, stdout=subprocess.DEVNULL)
    return 1000 * json.load(open(os.path.join(out, "eval.json")))["rpe"]["step"]["translation_m"]["rmse"]

def main():
    if len(sys.argv) != 6:
        sys.exit(__doc__)
    mcvo, a_csv, a_runs, b_csv, b_runs = sys.argv[1:]
    a, b = table(a_csv), table(b_csv)
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for key in sorted(a):
            if key not in b:
                continue
            seq, config = key
            one = number(a[key], "cameras") == 1
            run = f"{seq}.{config}"
            rows.append([seq, config,
                         number(a[key], "ate_percent_of_path"), number(b[key], "ate_percent_of_path"),
                         number(a[key], "scale_error_percent"), number(b[key], "scale_error_percent"),
                         step_mm(mcvo, os.path.join(a_runs, run), one, scratch),
                         step_mm(mcvo, os.path.join(b_runs, run), one, scratch),
                         f"{a[key]['frames_posed']} / {b[key]['frames_posed']}"])
    cell = lambda v, d: "-" if v is None else f"{v:.{d}f}"
    print("| sequence | config | ATE % A | ATE % B | scale error % A | B | RPE step mm A | B | posed A / B |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {cell(r[2], 3)} | {cell(r[3], 3)} | {cell(r[4], 3)} | {cell(r[5], 3)} | "
              f"{cell(r[6], 2)} | {cell(r[7], 2)} | {r[8]} |")
    print()
    for i, name in [(2, "ATE %"), (4, "scale error %"), (6, "RPE step mm")]:
        pairs = [(r[i], r[i + 1]) for r in rows if r[i] is not None and r[i + 1] is not None]
        if not pairs:
            continue
        print(f"* {name}: median {statistics.median(p[0] for p in pairs):.3f} -> "
              f"{statistics.median(p[1] for p in pairs):.3f}, worst {max(p[0] for p in pairs):.3f} -> "
              f"{max(p[1] for p in pairs):.3f}; B better in {sum(p[1] < p[0] for p in pairs)}, worse in "
              f"{sum(p[1] > p[0] for p in pairs)}, equal in {sum(p[1] == p[0] for p in pairs)} of {len(pairs)} runs")

main()
