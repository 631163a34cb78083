// Self-contained evaluation reports: report.html (one file, inline SVG plots
// drawn here, no script, no network) and report.md (the same tables in
// Markdown). Independent of the back end: the caller fills ReportInputs
// from whatever it has (an EvalResult, trajectories, a scale log, a config).
// Layout and every plot are described in docs/eval.md, "Reports".
//
//   ReportInputs report;
//   report.title = "kitti360 seq 0000, 4 cameras";
//   report.eval = &result;                    // EvaluateTrajectory(...); nullptr without ground truth
//   report.ground_truth = gt;                 // optional
//   report.estimate = result.est_aligned;     // optional when eval is set (defaults to it)
//   report.estimate_before_loop_closure = ApplyAlignment(before, result.gt_world_from_est_world);
//   for (const ScaleLogEntry& e : scale_log) {  // backend/estimator.h
//     report.scale_log.push_back(
//         {e.frame_index, e.t_ns, e.segment, e.event, e.camera_scales, e.applied, e.note});
//   }
//   report.camera_names = {"image_00", "image_01", ...};
//   report.settings = resolved_config_json;   // nlohmann::ordered_json
//   report.summary_rows = {{"version", "0.1.0"}, {"posed frames", "1575 / 1575"}};
//   WriteReports(out_dir, report);            // report.html, report.md
//
// Determinism: the same inputs give byte-identical files (numbers through
// FormatFixed / nlohmann's shortest form, no dates, no map iteration).
// Anything the caller puts in summary_rows or settings (a frame rate, a
// wall time) is written as given, so keep those out when the report must
// compare byte for byte.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "mcvo/eval/evaluate.h"
#include "mcvo/geometry/sim3d.h"
#include "mcvo/io/trajectory_io.h"

namespace mcvo {

// One scale event (a line of `mcvo run`'s scale_log.csv, docs/run-outputs.md).
// Field order follows backend's ScaleLogEntry, so the conversion is one
// brace list.
struct ReportScaleEntry {
  int64_t frame_index = -1;
  int64_t t_ns = 0;
  int segment = 0;
  // "init" / "reinit": camera_scales are the SfM scales of the initialisation
  //   (the plotted per-camera scale restarts at 1);
  // "lost": tracking lost, no scales;
  // anything else ("correction"): camera_scales are the per-camera ratios
  //   (1: unchanged); when applied, the plotted scale is multiplied by them.
  std::string event;
  std::vector<double> camera_scales;
  bool applied = false;
  std::string note;
};

struct ReportInputs {
  std::string title;
  // The evaluation against ground truth, or nullptr when there is none. Not
  // owned; must outlive the Render/Write call.
  const EvalResult* eval = nullptr;
  // World_from_body poses in the ground-truth frame (may be empty).
  Trajectory ground_truth;
  // The estimate, aligned to the ground truth when there is one. When empty
  // and eval is set, eval->est_aligned is used.
  Trajectory estimate;
  // Before loop closure, aligned the same way (ApplyAlignment with the same
  // gt_world_from_est_world): drawn beside the estimate.
  std::optional<Trajectory> estimate_before_loop_closure;
  // Its legend entry (the odometry before loop closure, or before the global
  // bundle adjustment when no loop was applied).
  std::string before_label = "before loop closure";
  std::vector<ReportScaleEntry> scale_log;
  // Names of the cameras, in the order of ReportScaleEntry::camera_scales
  // (missing names read "camera <i>").
  std::vector<std::string> camera_names;
  // The run's resolved configuration or the eval options; shown flattened
  // as a key/value table ("backend.window_size | 10"). Null: none.
  nlohmann::ordered_json settings;
  // Extra summary lines (version, frames/s, posed frames, ...), after the
  // ones taken from eval, in this order.
  std::vector<std::pair<std::string, std::string>> summary_rows;
};

// Every pose mapped by gt_world_from_est_world (Sim3d::TransformPose), time
// stamps and frame indices kept: EvalResult::est_aligned for another
// trajectory of the same run (e.g. before loop closure).
Trajectory ApplyAlignment(const Trajectory& estimate, const Sim3d& gt_world_from_est_world);

// The whole report.html (UTF-8, <!DOCTYPE html> ... </html>, trailing newline).
// Plots (each an <svg> with that id): plot-trajectory, plot-translation-error,
// plot-rotation-error, plot-rpe-translation, plot-rpe-rotation, plot-scale;
// the error and RPE plots only with eval, the scale plot only with a scale
// log. Every polyline has at most 2000 points.
std::string RenderReportHtml(const ReportInputs& inputs);

// report.md: the same summary and tables (plots point to report.html).
std::string RenderReportMarkdown(const ReportInputs& inputs);

// Creates `dir` and writes report.html and report.md atomically.
void WriteReports(const std::filesystem::path& dir, const ReportInputs& inputs);

}  // namespace mcvo
