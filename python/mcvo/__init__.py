"""mcvo: offline multi-camera visual odometry, from Python (docs/python.md).

The same library as the `mcvo` executable: ``mcvo.run`` writes the files
``mcvo run`` writes, byte for byte, and ``mcvo.evaluate`` gives the numbers
of ``mcvo eval``.

    import mcvo
    dataset = mcvo.open_dataset("seq/stereo")
    run = mcvo.run(dataset, config="config/kitti360_2cam.json", out="runs/stereo")
    run.trajectory          # N x 8 float64: t tx ty tz qx qy qz qw
    mcvo.evaluate(dataset.ground_truth, run)["ate"]
"""

import csv as _csv
import json as _json
import os as _os
import tempfile as _tempfile

from ._mcvo import (  # noqa: F401  (re-exported)
    Camera,
    Dataset,
    InputError,
    Rig,
    UsageError,
    __version__,
    log_level,
    open_dataset,
    read_trajectory,
    set_log_level,
    synth,
    write_trajectory,
)
from . import _mcvo

__all__ = [
    "Camera", "Dataset", "InputError", "Rig", "Run", "UsageError", "__version__", "evaluate", "log_level",
    "open_dataset", "read_csv_columns", "read_run", "read_trajectory", "run", "set_log_level", "synth",
    "write_trajectory",
]

for _cls in (Camera, Dataset, Rig, InputError, UsageError):
    _cls.__module__ = "mcvo"

# Output files of a run (docs/run-outputs.md): Run.paths keys.
_RUN_FILES = {
    "trajectory": "trajectory.tum",
    "trajectory_kitti": "trajectory_kitti.txt",
    "trajectory_euroc": "trajectory_euroc.csv",
    "keyframes": "keyframes.tum",
    "scale_log": "scale_log.csv",
    "frame_stats": "frame_stats.csv",
    "timing": "timing.csv",
    "run_json": "run.json",
    "report_html": "report.html",
    "report_md": "report.md",
    "eval": "eval",
    "colmap": "colmap",
    "loops": "loops.csv",
}


def _column(values):
    """One CSV column as a numpy array: int64, float64 (NaN for empty cells) or str."""
    import numpy as np

    filled = [v for v in values if v != ""]
    try:
        ints = [int(v) for v in filled]
        if len(filled) == len(values):
            return np.array(ints, dtype=np.int64)
    except ValueError:
        pass
    try:
        return np.array([float(v) if v != "" else np.nan for v in values], dtype=np.float64)
    except ValueError:
        return np.array(values, dtype=str)


def read_csv_columns(path):
    """A CSV file with a header line as a dict: column name -> numpy array (int64, float64 or str)."""
    with open(path, newline="") as f:
        rows = list(_csv.reader(f))
    if not rows:
        raise InputError(f"{path}: empty file (expected a header line)")
    header, body = rows[0], rows[1:]
    for i, row in enumerate(body):
        if len(row) != len(header):
            raise InputError(f"{path}:{i + 2}: expected {len(header)} fields, got {len(row)}")
    return {name: _column([row[k] for row in body]) for k, name in enumerate(header)}


class Run:
    """The outputs of one run (docs/run-outputs.md), as mcvo.run returns them and mcvo.read_run reads them.

    Attributes:
      out_dir      the output folder (absolute)
      trajectory   every posed frame, N x 8 float64 (t tx ty tz qx qy qz qw; world_from_rig)
      keyframes    the keyframe poses, K x 8 float64, same columns
      scale_log    scale_log.csv as a dict of numpy columns
      frame_stats  frame_stats.csv as a dict of numpy columns
      manifest     run.json as a dict (config, dataset, input and output hashes, result, timing)
      evaluation   eval/eval.json as a dict when the dataset had ground truth, else None
      paths        output name -> path of the files that exist (trajectory, keyframes, scale_log,
                   frame_stats, run_json, eval, report_html, ...)
      summary      what mcvo.run reported (frames, posed_frames, ate_rmse_m, ...); from run.json's
                   "result" for mcvo.read_run
    """

    def __init__(self, out_dir, summary=None):
        out_dir = _os.path.abspath(_os.fspath(out_dir))
        run_json = _os.path.join(out_dir, "run.json")
        if not _os.path.isfile(run_json):
            raise InputError(f"{out_dir}: not the output of a run (no run.json)")
        self.out_dir = out_dir
        self.paths = {}
        for key, name in _RUN_FILES.items():
            path = _os.path.join(out_dir, name)
            if _os.path.exists(path):
                self.paths[key] = path
        with open(run_json) as f:
            self.manifest = _json.load(f)
        self.trajectory = read_trajectory(self.paths["trajectory"], "tum")
        self.keyframes = read_trajectory(self.paths["keyframes"], "tum")
        self.scale_log = read_csv_columns(self.paths["scale_log"])
        self.frame_stats = read_csv_columns(self.paths["frame_stats"])
        eval_json = _os.path.join(out_dir, "eval", "eval.json")
        self.evaluation = None
        if _os.path.isfile(eval_json):
            with open(eval_json) as f:
                self.evaluation = _json.load(f)
        self.summary = summary if summary is not None else dict(self.manifest.get("result", {}))

    def __repr__(self):
        return f"<mcvo.Run {self.out_dir!r}: {len(self.trajectory)} poses, {len(self.keyframes)} keyframes>"


def read_run(out_dir):
    """The outputs of an earlier run (mcvo run or mcvo.run) in out_dir, as a Run."""
    return Run(out_dir)


def run(dataset, config=None, out=None, threads=None, progress=None, frames=0, force=False, tracks=None,
        detector=None, model=None):
    """Runs the pipeline of `mcvo run` on a dataset and returns its outputs as a Run.

    dataset   a Dataset (mcvo.open_dataset) or a dataset folder (any layout, detected)
    config    None (built-in defaults), a config file path, or a dict of the same keys (docs/config.md),
              validated exactly like the file (errors name "<dict>" and the JSON pointer)
    out       the output folder: must not exist or be empty, unless force; None: a new temporary folder
    threads   worker threads (0: all cores; None: the config's); results do not depend on it
    progress  called as progress(event) with {"stage": "start" | "running" | "done", "elapsed_s",
              "frames"} about twice a second; an exception it raises cancels the run
    frames    run the first N frames only (0: all)
    tracks, detector, model   as --tracks, --detector, --model of `mcvo run`

    The work runs without the GIL. Ctrl-C (KeyboardInterrupt) cancels it at its next safe point:
    nothing is left at out, and KeyboardInterrupt is raised. Bad input raises InputError.
    """
    if out is None:
        out = _tempfile.mkdtemp(prefix="mcvo-run-")
    summary = _mcvo._run_pipeline(dataset, out, config=config, threads=threads, frames=frames, force=force,
                                  progress=progress, tracks=tracks, detector=detector, model=model)
    return Run(summary.pop("out"), summary)


def evaluate(gt, est, align="auto", associate="auto", max_dt=0.01, align_frames=0, rpe_lengths=None,
             rpe_percents=None, gt_format="auto", est_format="auto", gt_times=None, est_times=None, out=None,
             force=False):
    """Scores an estimate against ground truth as `mcvo eval` does; returns eval.json as a dict.

    gt, est   trajectory files (any format, detected), N x 8 arrays in TUM order, a Run (its
              trajectory.tum) or, for gt, a Dataset (its ground truth)
    align     auto | se3 | sim3 | posyaw | none; auto: se3, but for an estimate beside an mcvo
              run.json whose scale is arbitrary (one camera) sim3, with the ground truth moved to
              the camera centre the run's poses are of (as `mcvo eval --align auto`)
    out       also write eval.json, eval.md, ate_errors.csv, est_aligned.tum and the reports there
    """
    if isinstance(est, Run):
        est = est.paths["trajectory"]
    if isinstance(gt, Run):
        raise UsageError("gt: a Run is an estimate; pass the dataset or its ground-truth file")
    if isinstance(gt, Dataset):
        if gt.ground_truth is None:
            raise InputError(f"{gt.root}: the dataset has no ground truth")
        gt = gt.ground_truth
    return _mcvo._evaluate(gt, est, align=align, associate=associate, max_dt=max_dt, align_frames=align_frames,
                           rpe_lengths=rpe_lengths, rpe_percents=rpe_percents, gt_format=gt_format,
                           est_format=est_format, gt_times=gt_times, est_times=est_times, out=out, force=force)
