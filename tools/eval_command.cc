// `mcvo eval`: scores an estimated trajectory against ground truth (ATE, RPE,
// scale, start-end discrepancy). Definitions in docs/eval.md.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command.h"
#include "mcvo/eval/evaluate.h"
#include "mcvo/eval/report.h"
#include "mcvo/eval/report_html.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/pipeline/run_manifest.h"
#include "mcvo/util/args.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/output_folder.h"
#include "mcvo/util/strings.h"

namespace mcvo::tools {
namespace {

std::vector<double> ParseList(const std::string& option, const std::string& text) {
  std::vector<double> values;
  for (std::string_view field : SplitFields(text, ',')) {
    const std::optional<double> value = ParseDouble(field);
    if (!value || !std::isfinite(*value) || !(*value > 0.0)) {
      throw UsageError(StrCat("--", option, ": expected comma-separated positive numbers, got '", text, "'"));
    }
    values.push_back(*value);
  }
  if (values.empty()) throw UsageError(StrCat("--", option, ": expected at least one value"));
  return values;
}

// What the run.json beside an estimate says about it (`mcvo run` output):
// its scale is arbitrary (one camera), and the rig origin its poses are of
// was moved (a one-camera rig's: to the camera centre), in the rig frame.
// A run.json that is not there or cannot be read says nothing.
struct RunFacts {
  bool scale_arbitrary = false;
  std::optional<Eigen::Vector3d> origin_in_rig_m;
};

RunFacts ReadRunFacts(const std::filesystem::path& est_path) {
  RunFacts facts;
  const std::filesystem::path run_json = est_path.parent_path() / "run.json";
  std::error_code ec;
  if (!std::filesystem::is_regular_file(run_json, ec)) return facts;
  try {
    const RunHeadline headline = RunManifest::Read(run_json).Headline();
    facts.scale_arbitrary = headline.scale_arbitrary;
    facts.origin_in_rig_m = headline.trajectory_origin_in_rig_m;
  } catch (const std::exception&) {
    return RunFacts();
  }
  return facts;
}

// std::nullopt for "auto" (detect from the file).
std::optional<TrajectoryFormat> ParseFormatOption(const std::string& option, const std::string& name) {
  if (name == "auto") return std::nullopt;
  const std::optional<TrajectoryFormat> format = TrajectoryFormatFromName(name);
  if (!format) {
    throw UsageError(
        StrCat("--", option, ": expected auto, tum, kitti, kitti-indexed or euroc, got '", name, "'"));
  }
  return format;
}

int RunEval(int argc, const char* const* argv) {
  std::string gt_path, est_path, gt_format = "auto", est_format = "auto", align = "auto", associate = "auto";
  std::string rpe_lengths, rpe_percents, gt_times, est_times, out_dir;
  int align_frames = 0;
  bool force = false;
  double max_dt = AssociationOptions().max_dt_s;

  ArgParser args("mcvo eval",
                 "Scores an estimated trajectory against ground truth: ATE, RPE, scale, start-end.");
  args.AddString("gt", &gt_path, "FILE", "ground-truth trajectory (TUM, KITTI, KITTI-360 poses, EuRoC CSV)",
                 true);
  args.AddString("est", &est_path, "FILE", "estimated trajectory", true);
  args.AddString("gt-format", &gt_format, "F", "auto|tum|kitti|kitti-indexed|euroc");
  args.AddString("est-format", &est_format, "F", "auto|tum|kitti|kitti-indexed|euroc");
  args.AddString("align", &align, "MODE",
                 "auto|se3|sim3|posyaw|none (auto: se3, but for an `mcvo run` trajectory whose run.json "
                 "says \"scale\": \"arbitrary\" (one camera) sim3, the ground truth moved to the "
                 "camera centre the run's poses are of)");
  args.AddInt("align-frames", &align_frames, "align on the first N matched poses (0: all)");
  args.AddString("associate", &associate, "MODE",
                 "time|index (auto: time when both trajectories have time stamps, else index)");
  args.AddDouble("max-dt", &max_dt, "largest time difference of an associated pair, seconds");
  args.AddString("rpe-lengths", &rpe_lengths, "M,M,...",
                 "RPE lengths in metres (e.g. 100,200,...,800 for KITTI)");
  args.AddString(
      "rpe-percents", &rpe_percents, "P,P,...",
      "RPE lengths in % of the ground-truth path, when --rpe-lengths is not given [default: 10,20,30,40,50]");
  args.AddString("gt-times", &gt_times, "FILE", "times file for a KITTI ground truth (one time per line)");
  args.AddString("est-times", &est_times, "FILE", "times file for a KITTI estimate");
  args.AddString("out", &out_dir, "DIR",
                 "write eval.json, eval.md, ate_errors.csv, est_aligned.tum, report.html, report.md there");
  args.AddFlag("force", &force, "replace a non-empty --out folder that an earlier mcvo eval wrote");
  args.AddEpilog(
      "Prints a Markdown summary on stdout. Definitions and every JSON key: docs/eval.md.\n"
      "example: mcvo eval --gt poses.txt --est est.txt --rpe-lengths 100,200,300,400,500,600,700,800 --out "
      "res/\n");
  if (!args.Parse(argc, argv)) return kExitOk;

  // Every command-line check before any file is read.
  EvalOptions options;
  const std::optional<AlignmentMode> align_mode =
      align == "auto" ? std::optional<AlignmentMode>(AlignmentMode::kSe3) : AlignmentModeFromName(align);
  if (!align_mode)
    throw UsageError(StrCat("--align: expected auto, se3, sim3, posyaw or none, got '", align, "'"));
  options.align = *align_mode;
  if (align_frames < 0)
    throw UsageError(StrCat("--align-frames: expected 0 (all) or a count, got ", align_frames));
  options.align_num_poses = align_frames;
  std::optional<AssociationMode> association_mode;
  if (associate != "auto") {
    association_mode = AssociationModeFromName(associate);
    if (!association_mode)
      throw UsageError(StrCat("--associate: expected time, index or auto, got '", associate, "'"));
  }
  options.association.max_dt_s = max_dt;
  if (!rpe_lengths.empty()) options.rpe_lengths_m = ParseList("rpe-lengths", rpe_lengths);
  if (!rpe_percents.empty()) {
    if (!rpe_lengths.empty()) throw UsageError("--rpe-lengths and --rpe-percents exclude each other");
    options.rpe_length_percents = ParseList("rpe-percents", rpe_percents);
  }
  try {
    options.Check();
  } catch (const UsageError& e) {
    throw UsageError(StrCat("invalid option value: ", e.what(), " (see --help)"));
  }
  const std::optional<TrajectoryFormat> gt_format_given = ParseFormatOption("gt-format", gt_format);
  const std::optional<TrajectoryFormat> est_format_given = ParseFormatOption("est-format", est_format);

  const TrajectoryFormat gt_file_format =
      gt_format_given ? *gt_format_given : DetectTrajectoryFormat(gt_path);
  const TrajectoryFormat est_file_format =
      est_format_given ? *est_format_given : DetectTrajectoryFormat(est_path);
  const RunFacts facts = align == "auto" ? ReadRunFacts(est_path) : RunFacts();
  const std::string run_json = (std::filesystem::path(est_path).parent_path() / "run.json").string();
  if (facts.scale_arbitrary) {
    options.align = AlignmentMode::kSim3;
    std::cerr << "mcvo eval: --align auto: sim3 (" << run_json << ": the scale is arbitrary, one camera)\n";
  }
  Trajectory gt = ReadTrajectory(gt_path, gt_file_format);
  if (facts.origin_in_rig_m) {
    // The estimate is of a point other than the rig origin: the ground truth moves there too.
    const Eigen::Vector3d& c = *facts.origin_in_rig_m;
    for (StampedPose& pose : gt.poses) {
      pose.world_from_body = pose.world_from_body * Rigid3d(Eigen::Quaterniond::Identity(), c);
    }
    std::cerr << "mcvo eval: --align auto: ground truth moved to the estimate's origin, ("
              << FormatDouble(c.x()) << ", " << FormatDouble(c.y()) << ", " << FormatDouble(c.z())
              << ") m in the rig frame (" << run_json << ")\n";
  }
  Trajectory est = ReadTrajectory(est_path, est_file_format);
  if (!gt_times.empty()) ApplyTimesFile(gt_times, &gt);
  if (!est_times.empty()) ApplyTimesFile(est_times, &est);
  options.association.mode = association_mode.value_or(gt.has_time && est.has_time ? AssociationMode::kTime
                                                                                   : AssociationMode::kIndex);

  const EvalResult result = EvaluateTrajectory(gt, est, options, gt_path, est_path);
  if (!out_dir.empty()) {
    // The output folder discipline of every command (util/output_folder.h).
    OutputFolderOptions out_options;
    out_options.force = force;
    out_options.kind = "eval";
    out_options.inputs = {gt_path, est_path, gt_times, est_times};
    OutputFolder out(out_dir, out_options);
    WriteEvalOutputs(out.staging(), result);
    // report.html / report.md: the same result with plots; the eval options
    // come from the result itself, the files and formats from here.
    ReportInputs report;
    report.title = StrCat(std::filesystem::path(est_path).filename().string(), " vs ",
                          std::filesystem::path(gt_path).filename().string());
    report.eval = &result;
    report.ground_truth = gt;
    report.settings["gt"] = gt_path;
    report.settings["gt_format"] = std::string(TrajectoryFormatName(gt_file_format));
    if (!gt_times.empty()) report.settings["gt_times"] = gt_times;
    report.settings["est"] = est_path;
    report.settings["est_format"] = std::string(TrajectoryFormatName(est_file_format));
    if (!est_times.empty()) report.settings["est_times"] = est_times;
    WriteReports(out.staging(), report);
    out.Commit();
  }
  std::cout << EvalResultToMarkdown(result);
  return kExitOk;
}

const CommandRegistrar kRegistrar("eval",
                                  {"score a trajectory against ground truth (ATE, RPE, scale)", RunEval});

}  // namespace
}  // namespace mcvo::tools
