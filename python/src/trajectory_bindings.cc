// Trajectory files as numpy arrays and the evaluation of `mcvo eval`
// (io/trajectory_io.h, eval/evaluate.h; tools/eval_command.cc is the
// command line this mirrors, "align auto" included).
#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "bindings.h"
#include "mcvo/eval/evaluate.h"
#include "mcvo/eval/report.h"
#include "mcvo/eval/report_html.h"
#include "mcvo/pipeline/run_manifest.h"
#include "mcvo/util/error.h"
#include "mcvo/util/output_folder.h"
#include "mcvo/util/strings.h"

namespace mcvo::python {

py::array_t<double> TrajectoryToArray(const Trajectory& trajectory) {
  py::array_t<double> array(std::vector<py::ssize_t>{static_cast<py::ssize_t>(trajectory.poses.size()), 8});
  double* out = array.mutable_data();
  for (const StampedPose& pose : trajectory.poses) {
    const Eigen::Quaterniond& q = pose.world_from_body.rotation;
    const Eigen::Vector3d& t = pose.world_from_body.translation;
    const double row[8] = {trajectory.has_time ? static_cast<double>(pose.t_ns) / 1e9 : std::nan(""),
                           t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
    for (double value : row) *out++ = value;
  }
  return array;
}

Trajectory ArrayToTrajectory(const py::array_t<double, py::array::c_style | py::array::forcecast>& array,
                             const std::string& what) {
  if (array.ndim() != 2 || array.shape(1) != 8) {
    throw UsageError(StrCat(what, ": expected an N x 8 array (t tx ty tz qx qy qz qw)"));
  }
  const py::ssize_t rows = array.shape(0);
  const double* in = array.data();
  Trajectory trajectory;
  trajectory.has_time = true;
  for (py::ssize_t i = 0; i < rows; ++i) {
    if (!std::isfinite(in[8 * i])) trajectory.has_time = false;
  }
  trajectory.has_frame_index = !trajectory.has_time;
  for (py::ssize_t i = 0; i < rows; ++i) {
    const double* r = in + 8 * i;
    for (int k = 1; k < 8; ++k) {
      if (!std::isfinite(r[k])) throw InputError(StrCat(what, ": row ", i, ": non-finite pose"));
    }
    const Eigen::Quaterniond q(r[7], r[4], r[5], r[6]);
    if (std::abs(1.0 - q.norm()) > 1e-3) throw InputError(StrCat(what, ": row ", i, ": quaternion far from unit norm"));
    StampedPose pose;
    pose.t_ns = trajectory.has_time ? std::llround(r[0] * 1e9) : 0;
    pose.frame_index = trajectory.has_time ? -1 : i;
    pose.world_from_body = Rigid3d(q, Eigen::Vector3d(r[1], r[2], r[3]));
    trajectory.poses.push_back(pose);
  }
  return trajectory;
}

namespace {

std::optional<TrajectoryFormat> FormatOption(const std::string& option, const std::string& name) {
  if (name == "auto") return std::nullopt;
  const std::optional<TrajectoryFormat> format = TrajectoryFormatFromName(name);
  if (!format) {
    throw UsageError(StrCat(option, ": expected auto, tum, kitti, kitti-indexed or euroc, got '", name, "'"));
  }
  return format;
}

Trajectory ReadTrajectoryFile(const std::string& path, const std::string& format, const py::object& times,
                              TrajectoryFormat* read_as) {
  const std::optional<TrajectoryFormat> given = FormatOption("format", format);
  *read_as = given ? *given : DetectTrajectoryFormat(path);
  Trajectory trajectory = ReadTrajectory(path, *read_as);
  if (!times.is_none()) ApplyTimesFile(PathString(times), &trajectory);
  return trajectory;
}

std::vector<double> PositiveList(const char* option, const std::vector<double>& values) {
  if (values.empty()) throw UsageError(StrCat(option, ": expected at least one value"));
  for (double v : values) {
    if (!std::isfinite(v) || !(v > 0.0)) throw UsageError(StrCat(option, ": expected positive numbers"));
  }
  return values;
}

// One side of an evaluation: a file (read as `mcvo eval` reads it) or an N x 8 array.
struct EvalInput {
  Trajectory trajectory;
  std::string name;
  std::string path;  // empty for an array
  TrajectoryFormat format = TrajectoryFormat::kTum;
};

EvalInput ReadEvalInput(const py::object& source, const char* what, const std::string& format,
                        const py::object& times) {
  EvalInput input;
  if (py::isinstance<py::str>(source) || py::hasattr(source, "__fspath__")) {
    input.path = PathString(source);
    input.name = input.path;
    input.trajectory = ReadTrajectoryFile(input.path, format, times, &input.format);
  } else {
    input.name = what;
    input.trajectory = ArrayToTrajectory(source.cast<py::array_t<double, py::array::c_style | py::array::forcecast>>(),
                                         what);
    if (!times.is_none()) ApplyTimesFile(PathString(times), &input.trajectory);
  }
  return input;
}

struct EvalArgs {
  std::string align = "auto";
  std::string associate = "auto";
  double max_dt = AssociationOptions().max_dt_s;
  int align_frames = 0;
  std::optional<std::vector<double>> rpe_lengths;
  std::optional<std::vector<double>> rpe_percents;
};

EvalOptions CheckedEvalOptions(const EvalArgs& args, std::optional<AssociationMode>* association) {
  EvalOptions options;
  const std::optional<AlignmentMode> mode =
      args.align == "auto" ? std::optional<AlignmentMode>(AlignmentMode::kSe3) : AlignmentModeFromName(args.align);
  if (!mode) throw UsageError(StrCat("align: expected auto, se3, sim3, posyaw or none, got '", args.align, "'"));
  options.align = *mode;
  if (args.align_frames < 0) {
    throw UsageError(StrCat("align_frames: expected 0 (all) or a count, got ", args.align_frames));
  }
  options.align_num_poses = args.align_frames;
  if (args.associate != "auto") {
    *association = AssociationModeFromName(args.associate);
    if (!*association) throw UsageError(StrCat("associate: expected time, index or auto, got '", args.associate, "'"));
  }
  options.association.max_dt_s = args.max_dt;
  if (args.rpe_lengths) options.rpe_lengths_m = PositiveList("rpe_lengths", *args.rpe_lengths);
  if (args.rpe_percents) {
    if (args.rpe_lengths) throw UsageError("rpe_lengths and rpe_percents exclude each other");
    options.rpe_length_percents = PositiveList("rpe_percents", *args.rpe_percents);
  }
  try {
    options.Check();
  } catch (const UsageError& e) {
    throw UsageError(StrCat("invalid option value: ", e.what()));
  }
  return options;
}

// `mcvo eval --align auto` on an `mcvo run` trajectory: what its run.json says
// (tools/eval_command.cc ReadRunFacts).
void ApplyRunFacts(const std::string& est_path, EvalOptions* options, Trajectory* gt) {
  const std::filesystem::path run_json = std::filesystem::path(est_path).parent_path() / "run.json";
  std::error_code ec;
  if (!std::filesystem::is_regular_file(run_json, ec)) return;
  RunHeadline headline;
  try {
    headline = RunManifest::Read(run_json).Headline();
  } catch (const std::exception&) {
    return;
  }
  if (headline.scale_arbitrary) options->align = AlignmentMode::kSim3;
  if (headline.trajectory_origin_in_rig_m) {
    const Eigen::Vector3d& c = *headline.trajectory_origin_in_rig_m;
    for (StampedPose& pose : gt->poses) {
      pose.world_from_body = pose.world_from_body * Rigid3d(Eigen::Quaterniond::Identity(), c);
    }
  }
}

void WriteEvalFolder(const std::string& out_dir, bool force, const EvalResult& result, const EvalInput& gt,
                     const EvalInput& est, const std::string& gt_times, const std::string& est_times) {
  OutputFolderOptions out_options;
  out_options.force = force;
  out_options.kind = "eval";
  out_options.inputs = {gt.path, est.path, gt_times, est_times};
  OutputFolder out(out_dir, out_options);
  WriteEvalOutputs(out.staging(), result);
  ReportInputs report;
  report.title = StrCat(std::filesystem::path(est.name).filename().string(), " vs ",
                        std::filesystem::path(gt.name).filename().string());
  report.eval = &result;
  report.ground_truth = gt.trajectory;
  report.settings["gt"] = gt.name;
  if (!gt.path.empty()) report.settings["gt_format"] = std::string(TrajectoryFormatName(gt.format));
  if (!gt_times.empty()) report.settings["gt_times"] = gt_times;
  report.settings["est"] = est.name;
  if (!est.path.empty()) report.settings["est_format"] = std::string(TrajectoryFormatName(est.format));
  if (!est_times.empty()) report.settings["est_times"] = est_times;
  WriteReports(out.staging(), report);
  out.Commit();
}

py::object Evaluate(const py::object& gt_source, const py::object& est_source, const EvalArgs& args,
                    const std::string& gt_format, const std::string& est_format, const py::object& gt_times,
                    const py::object& est_times, const py::object& out, bool force) {
  std::optional<AssociationMode> association;
  EvalOptions options = CheckedEvalOptions(args, &association);
  FormatOption("gt_format", gt_format);
  FormatOption("est_format", est_format);
  EvalInput gt = ReadEvalInput(gt_source, "ground truth", gt_format, gt_times);
  const bool est_is_file = py::isinstance<py::str>(est_source) || py::hasattr(est_source, "__fspath__");
  if (args.align == "auto" && est_is_file) ApplyRunFacts(PathString(est_source), &options, &gt.trajectory);
  EvalInput est = ReadEvalInput(est_source, "estimate", est_format, est_times);
  options.association.mode = association.value_or(gt.trajectory.has_time && est.trajectory.has_time
                                                      ? AssociationMode::kTime
                                                      : AssociationMode::kIndex);
  const std::string out_dir = out.is_none() ? std::string() : PathString(out);
  const std::string gt_times_path = gt_times.is_none() ? std::string() : PathString(gt_times);
  const std::string est_times_path = est_times.is_none() ? std::string() : PathString(est_times);
  std::string json;
  {
    py::gil_scoped_release release;
    const EvalResult result = EvaluateTrajectory(gt.trajectory, est.trajectory, options, gt.name, est.name);
    json = EvalResultToJson(result);
    if (!out_dir.empty()) WriteEvalFolder(out_dir, force, result, gt, est, gt_times_path, est_times_path);
  }
  return py::module_::import("json").attr("loads")(json);
}

}  // namespace

void BindTrajectory(py::module_& m) {
  m.def(
      "read_trajectory",
      [](const py::object& path, const std::string& format, const py::object& times) {
        TrajectoryFormat read_as;
        return TrajectoryToArray(ReadTrajectoryFile(PathString(path), format, times, &read_as));
      },
      py::arg("path"), py::arg("format") = "auto", py::arg("times") = py::none(),
      "Reads a trajectory file (auto, tum, kitti, kitti-indexed, euroc) as N x 8 float64 in TUM order "
      "(t tx ty tz qx qy qz qw; t NaN without time stamps; times: a KITTI times file).");
  m.def(
      "write_trajectory",
      [](const py::object& path, const py::array_t<double, py::array::c_style | py::array::forcecast>& poses,
         const std::string& format) {
        const std::optional<TrajectoryFormat> f = TrajectoryFormatFromName(format);
        if (!f) throw UsageError(StrCat("format: expected tum, kitti, kitti-indexed or euroc, got '", format, "'"));
        WriteTrajectory(PathString(path), ArrayToTrajectory(poses, "poses"), *f);
      },
      py::arg("path"), py::arg("poses"), py::arg("format") = "tum",
      "Writes N x 8 poses (TUM order) atomically as tum, kitti, kitti-indexed (frame index = row) or euroc.");
  m.def(
      "_evaluate",
      [](const py::object& gt, const py::object& est, const std::string& align, const std::string& associate,
         double max_dt, int align_frames, std::optional<std::vector<double>> rpe_lengths,
         std::optional<std::vector<double>> rpe_percents, const std::string& gt_format,
         const std::string& est_format, const py::object& gt_times, const py::object& est_times,
         const py::object& out, bool force) {
        EvalArgs args;
        args.align = align;
        args.associate = associate;
        args.max_dt = max_dt;
        args.align_frames = align_frames;
        args.rpe_lengths = std::move(rpe_lengths);
        args.rpe_percents = std::move(rpe_percents);
        return Evaluate(gt, est, args, gt_format, est_format, gt_times, est_times, out, force);
      },
      py::arg("gt"), py::arg("est"), py::arg("align") = "auto", py::arg("associate") = "auto",
      py::arg("max_dt") = AssociationOptions().max_dt_s, py::arg("align_frames") = 0,
      py::arg("rpe_lengths") = py::none(), py::arg("rpe_percents") = py::none(), py::arg("gt_format") = "auto",
      py::arg("est_format") = "auto", py::arg("gt_times") = py::none(), py::arg("est_times") = py::none(),
      py::arg("out") = py::none(), py::arg("force") = false);
}

}  // namespace mcvo::python
