#!/usr/bin/env python3
"""Runs two configs on one dataset and plots both trajectories against the ground truth.

    PYTHONPATH=build/python python3 examples/python/compare_runs.py \
        [--dataset out/demo/kitti360] [--configs config/kitti360_4cam.json config/kitti360_2cam.json] \
        [--frames N] [--png out/compare_runs.png]

The dataset defaults to the one `make demo` renders (out/demo/kitti360); without it, a short
stereo sequence is rendered into out/compare_runs/. The runs go to out/compare_runs/<config>/.
Each trajectory is drawn as the evaluation aligns it to the ground truth (eval/est_aligned.tum,
the same alignment `mcvo eval` reports), seen from above (x-y plane of the ground truth's world),
beside its position error along the path (eval/ate_errors.csv).
"""

import argparse
import os
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt  # noqa: E402

import mcvo  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]


def parse_args():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--dataset", help="dataset folder (default: out/demo/kitti360, else a render)")
    parser.add_argument("--configs", nargs=2, metavar="JSON",
                        default=[str(ROOT / "config/kitti360_4cam.json"), str(ROOT / "config/kitti360_2cam.json")])
    parser.add_argument("--frames", type=int, default=0, help="first N frames only (0: all)")
    parser.add_argument("--out", default=str(ROOT / "out/compare_runs"), help="folder of the runs")
    parser.add_argument("--png", default=str(ROOT / "out/compare_runs.png"))
    return parser.parse_args()


def default_dataset(out):
    demo = ROOT / "out/demo/kitti360"
    if (demo / "frames.csv").is_file():
        return str(demo)
    render = pathlib.Path(out) / "kitti360"
    if not (render / "frames.csv").is_file():
        print(f"rendering a short kitti360 sequence into {render}", flush=True)
        mcvo.synth(str(render), preset="kitti360", frames=60, image_scale=0.5, samples=1, force=True)
    return str(render)


def main():
    args = parse_args()
    dataset_path = args.dataset or default_dataset(args.out)
    dataset = mcvo.open_dataset(dataset_path)
    if dataset.ground_truth is None:
        sys.exit(f"{dataset_path}: the dataset has no ground truth to compare with")
    print(f"{dataset!r}")

    fig, (ax, ax_err) = plt.subplots(1, 2, figsize=(14, 6), gridspec_kw={"width_ratios": [3, 2]})
    gt = dataset.ground_truth
    ax.plot(gt[:, 1], gt[:, 2], "k-", lw=2.5, label="ground truth")
    for config in args.configs:
        name = pathlib.Path(config).stem
        out = os.path.join(args.out, name)
        run = mcvo.run(dataset, config=config, out=out, frames=args.frames, force=True,
                       progress=lambda e: print(f"  {name}: {e['stage']} {e['elapsed_s']:.1f} s", flush=True)
                       if e["stage"] != "running" else None)
        if run.evaluation is None:
            print(f"  {name}: no frame posed, nothing to plot ({run.summary['warning']})")
            continue
        ate = run.evaluation["ate"]["translation_m"]["rmse"]
        path_m = run.evaluation["rpe"]["gt_path_length_m"]
        # The estimate as the evaluation aligned it to the ground truth.
        aligned = mcvo.read_trajectory(os.path.join(run.paths["eval"], "est_aligned.tum"))
        label = (f"{name}: ATE {ate:.3f} m ({100 * ate / path_m:.2f} % of {path_m:.0f} m), "
                 f"{len(run.trajectory)}/{run.summary['frames']} posed")
        line, = ax.plot(aligned[:, 1], aligned[:, 2], "-", lw=1.5, label=label)
        errors = mcvo.read_csv_columns(os.path.join(run.paths["eval"], "ate_errors.csv"))
        ax_err.plot(errors["t_s"] - gt[0, 0], 100 * errors["translation_error_m"], "-", color=line.get_color(),
                    label=name)
        print(f"  {label}")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    ax.set_title(f"{dataset.name}: {len(dataset)} frames, {len(dataset.rig)} cameras (top view)")
    ax_err.set_xlabel("time [s]")
    ax_err.set_ylabel("position error after alignment [cm]")
    ax_err.grid(True, alpha=0.3)
    ax_err.legend(loc="best")
    ax_err.set_title("ATE along the path")
    os.makedirs(os.path.dirname(os.path.abspath(args.png)), exist_ok=True)
    fig.savefig(args.png, dpi=120, bbox_inches="tight")
    print(f"wrote {args.png}")


if __name__ == "__main__":
    main()
