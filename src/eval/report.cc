#include "mcvo/eval/report.h"

#include <sstream>

#include <nlohmann/json.hpp>

#include "mcvo/util/strings.h"
#include "report_common.h"

namespace mcvo {
namespace {

using Json = nlohmann::ordered_json;

Json StatsJson(const ErrorStats& stats) {
  Json j;
  j["count"] = stats.count;
  const bool have = stats.count > 0;
  j["rmse"] = have ? Json(stats.rmse) : Json(nullptr);
  j["mean"] = have ? Json(stats.mean) : Json(nullptr);
  j["median"] = have ? Json(stats.median) : Json(nullptr);
  j["std"] = have ? Json(stats.std) : Json(nullptr);
  j["min"] = have ? Json(stats.min) : Json(nullptr);
  j["max"] = have ? Json(stats.max) : Json(nullptr);
  return j;
}

Json Optional(const std::optional<double>& value) { return value ? Json(*value) : Json(nullptr); }

Json OptionsJson(const EvalOptions& options) {
  Json j;
  j["associate"] = AssociationModeName(options.association.mode);
  j["max_dt_s"] = options.association.max_dt_s;
  j["align"] = AlignmentModeName(options.align);
  j["align_num_poses"] = options.align_num_poses;
  const bool metres = !options.rpe_lengths_m.empty();
  j["rpe_lengths_m"] = metres ? Json(options.rpe_lengths_m) : Json(nullptr);
  j["rpe_length_percents"] = metres ? Json(nullptr) : Json(options.rpe_length_percents);
  j["rpe_length_tolerance"] = options.rpe_length_tolerance;
  j["local_scale_window"] = options.local_scale_window;
  j["local_scale_min_distance_m"] = options.local_scale_min_distance_m;
  return j;
}

Json RpeJson(const EvalResult& result) {
  const RpeResult& rpe = result.rpe;
  Json j;
  j["computed"] = rpe.computed;
  j["skipped_reason"] = rpe.computed ? Json(nullptr) : Json(rpe.skipped_reason);
  j["gt_path_length_m"] = result.gt_matched_path_length_m;
  j["step"] = {{"count", rpe.step.translation_m.count},
               {"translation_m", StatsJson(rpe.step.translation_m)},
               {"rotation_deg", StatsJson(rpe.step.rotation_deg)}};
  Json lengths = Json::array();
  for (const RpeLengthResult& length : rpe.lengths) {
    Json l;
    l["length_m"] = length.length_m;
    l["length_percent"] = Optional(length.length_percent);
    l["count"] = length.translation_m.count;
    l["translation_m"] = StatsJson(length.translation_m);
    l["translation_percent"] = StatsJson(length.translation_percent);
    l["rotation_deg"] = StatsJson(length.rotation_deg);
    l["rotation_deg_per_m"] = StatsJson(length.rotation_deg_per_m);
    lengths.push_back(l);
  }
  j["lengths"] = lengths;
  Json average;
  const bool have = rpe.average.num_lengths > 0;
  average["num_lengths"] = rpe.average.num_lengths;
  average["translation_m"] = have ? Json(rpe.average.translation_m) : Json(nullptr);
  average["translation_percent"] = have ? Json(rpe.average.translation_percent) : Json(nullptr);
  average["rotation_deg"] = have ? Json(rpe.average.rotation_deg) : Json(nullptr);
  average["rotation_deg_per_m"] = have ? Json(rpe.average.rotation_deg_per_m) : Json(nullptr);
  j["average"] = average;
  return j;
}

Json ScaleJson(const EvalResult& result) {
  const ScaleResult& scale = result.scale;
  const bool have = scale.available;
  Json j;
  j["available"] = have;
  j["unavailable_reason"] = have ? Json(nullptr) : Json(scale.unavailable_reason);
  j["num_poses"] = scale.num_poses;
  j["sim3_scale"] = have ? Json(scale.sim3_scale) : Json(nullptr);
  j["est_scale_factor"] = have ? Json(scale.est_scale_factor) : Json(nullptr);
  j["scale_error_percent"] = have ? Json(scale.scale_error_percent) : Json(nullptr);
  j["scale_error_signed_percent"] = have ? Json(scale.scale_error_signed_percent) : Json(nullptr);
  Json drift = Json::array();
  for (const RpeLengthResult& length : result.rpe.lengths) {
    Json l;
    l["length_m"] = length.length_m;
    l["length_percent"] = Optional(length.length_percent);
    l["count"] = length.scale_ratio.count;
    l["ratio"] = StatsJson(length.scale_ratio);
    l["ratio_sim3_normalized"] = StatsJson(length.scale_ratio_sim3_normalized);
    drift.push_back(l);
  }
  j["drift"] = drift;
  const LocalScaleResult& local = result.local_scale;
  const bool have_local = local.ratio.count > 0;
  Json l;
  l["window_poses"] = local.window_poses;
  l["windows"] = local.ratio.count;
  l["windows_skipped"] = local.windows_skipped;
  l["ratio"] = StatsJson(local.ratio);
  l["worst_deviation_percent"] = have_local ? Json(local.worst_deviation_percent) : Json(nullptr);
  l["median_deviation_percent"] = have_local ? Json(local.median_deviation_percent) : Json(nullptr);
  j["local"] = l;
  return j;
}

// Fixed decimals for the human tables; "-" for a value that does not exist.
std::string Fixed(double value, int decimals = 4) { return FormatFixed(value, decimals); }
std::string StatOrDash(const ErrorStats& stats, double value, int decimals = 4) {
  return stats.count > 0 ? Fixed(value, decimals) : "-";
}

}  // namespace

std::string EvalResultToJson(const EvalResult& result) {
  Json j;
  j["format"] = "mcvo-eval";
  j["format_version"] = kEvalJsonVersion;
  j["gt"] = {{"name", result.gt_name}, {"poses", result.num_gt_poses}};
  j["est"] = {{"name", result.est_name}, {"poses", result.num_est_poses}};
  j["options"] = OptionsJson(result.options);

  const Association& a = result.association;
  Json association;
  association["mode"] = AssociationModeName(result.options.association.mode);
  association["matched"] = a.pairs.size();
  association["gt_unmatched"] = a.num_gt_unmatched;
  association["est_unmatched"] = a.num_est_unmatched;
  association["max_abs_dt_s"] = static_cast<double>(a.max_abs_dt_ns) * 1e-9;
  j["association"] = association;

  const Sim3d& s = result.gt_world_from_est_world;
  Json alignment;
  alignment["mode"] = AlignmentModeName(result.options.align);
  alignment["num_poses"] = result.num_alignment_poses;
  alignment["scale"] = s.scale;
  alignment["quaternion_wxyz"] = {s.rotation.w(), s.rotation.x(), s.rotation.y(), s.rotation.z()};
  alignment["translation"] = {s.translation.x(), s.translation.y(), s.translation.z()};
  alignment["collinear"] = result.alignment_collinear;
  j["alignment"] = alignment;

  j["ate"] = {{"translation_m", StatsJson(result.ate_translation_m)},
              {"rotation_deg", StatsJson(result.ate_rotation_deg)}};
  j["rpe"] = RpeJson(result);
  j["scale"] = ScaleJson(result);

  const StartEndResult& se = result.start_end;
  Json start_end;
  start_end["est_distance_m"] = se.est_distance_m;
  start_end["est_path_length_m"] = se.est_path_length_m;
  start_end["est_percent"] = Optional(se.est_percent);
  start_end["gt_distance_m"] = se.gt_distance_m;
  start_end["gt_path_length_m"] = se.gt_path_length_m;
  start_end["gt_percent"] = Optional(se.gt_percent);
  j["start_end"] = start_end;
  j["notes"] = result.notes;
  return j.dump(2) + "\n";
}

std::string EvalResultToMarkdown(const EvalResult& result) {
  std::ostringstream out;
  const Association& a = result.association;
  // The names are the user's file names and the reasons may quote them:
  // escaped, since Markdown viewers render inline HTML.
  const auto md = [](const std::string& text) { return report_internal::MdEscape(text, false); };
  out << "## mcvo eval: " << md(result.est_name) << " vs " << md(result.gt_name) << "\n\n";
  out << "matched " << a.pairs.size() << " of " << result.num_est_poses << " estimated and "
      << result.num_gt_poses << " ground-truth poses (associate "
      << AssociationModeName(result.options.association.mode);
  if (result.options.association.mode == AssociationMode::kTime) {
    out << ", max_dt " << FormatDouble(result.options.association.max_dt_s) << " s";
  }
  out << "); align " << AlignmentModeName(result.options.align);
  if (result.options.align != AlignmentMode::kNone) out << " on " << result.num_alignment_poses << " poses";
  out << "\n\n";

  out << "| ATE | rmse | mean | median | std | min | max | count |\n"
      << "|---|---|---|---|---|---|---|---|\n";
  const auto ate_row = [&out](const char* name, const ErrorStats& s) {
    out << "| " << name << " | " << StatOrDash(s, s.rmse) << " | " << StatOrDash(s, s.mean) << " | "
        << StatOrDash(s, s.median) << " | " << StatOrDash(s, s.std) << " | " << StatOrDash(s, s.min) << " | "
        << StatOrDash(s, s.max) << " | " << s.count << " |\n";
  };
  ate_row("translation (m)", result.ate_translation_m);
  ate_row("rotation (deg)", result.ate_rotation_deg);
  ate_row("RPE step, translation (m)", result.rpe.step.translation_m);
  ate_row("RPE step, rotation (deg)", result.rpe.step.rotation_deg);
  out << "\n";

  if (result.rpe.computed) {
    out << "| RPE length (m) | segments | trans (m) | trans (%) | rot (deg) | rot (deg/m) | est/gt distance "
           "|\n"
        << "|---|---|---|---|---|---|---|\n";
    for (const RpeLengthResult& l : result.rpe.lengths) {
      out << "| " << Fixed(l.length_m, 3);
      if (l.length_percent) out << " (" << FormatDouble(*l.length_percent) << " %)";
      out << " | " << l.translation_m.count << " | " << StatOrDash(l.translation_m, l.translation_m.mean)
          << " | " << StatOrDash(l.translation_percent, l.translation_percent.mean) << " | "
          << StatOrDash(l.rotation_deg, l.rotation_deg.mean) << " | "
          << StatOrDash(l.rotation_deg_per_m, l.rotation_deg_per_m.mean, 6) << " | "
          << StatOrDash(l.scale_ratio, l.scale_ratio.mean, 6) << " |\n";
    }
    const RpeAverage& avg = result.rpe.average;
    if (avg.num_lengths > 0) {
      out << "| average (" << avg.num_lengths << " lengths) | | " << Fixed(avg.translation_m) << " | "
          << Fixed(avg.translation_percent) << " | " << Fixed(avg.rotation_deg) << " | "
          << Fixed(avg.rotation_deg_per_m, 6) << " | |\n";
    }
    out << "\nRPE values are means over the segments of each length.\n\n";
  } else {
    out << "RPE skipped: " << md(result.rpe.skipped_reason) << "\n\n";
  }

  const ScaleResult& scale = result.scale;
  if (scale.available) {
    out << "scale: sim3 " << Fixed(scale.sim3_scale, 6) << " (est -> gt); estimate is "
        << Fixed(scale.est_scale_factor, 6) << " x true size; scale error "
        << Fixed(scale.scale_error_percent, 3) << " %\n";
  } else {
    out << "scale: not available (" << md(scale.unavailable_reason) << ")\n";
  }
  const StartEndResult& se = result.start_end;
  out << "start-end: est " << Fixed(se.est_distance_m) << " m"
      << (se.est_percent
              ? " (" + Fixed(*se.est_percent, 3) + " % of " + Fixed(se.est_path_length_m, 3) + " m)"
              : "")
      << ", gt " << Fixed(se.gt_distance_m) << " m"
      << (se.gt_percent ? " (" + Fixed(*se.gt_percent, 3) + " % of " + Fixed(se.gt_path_length_m, 3) + " m)"
                        : "")
      << "\n";
  if (!result.notes.empty()) {
    out << "\nnotes:\n";
    for (const std::string& note : result.notes) out << "- " << md(note) << "\n";
  }
  return out.str();
}

std::string AteErrorsCsv(const EvalResult& result) {
  std::ostringstream out;
  out << "est_index,gt_index,t_s,frame_index,translation_error_m,rotation_error_deg\n";
  const Trajectory& est = result.est_aligned;
  for (const PoseError& e : result.pose_errors) {
    const StampedPose& pose = est.poses[e.est_index];
    out << e.est_index << "," << e.gt_index << "," << (est.has_time ? FormatNsAsSeconds(pose.t_ns) : "")
        << "," << (est.has_frame_index ? std::to_string(pose.frame_index) : "") << ","
        << FormatDouble(e.translation_m) << "," << FormatDouble(e.rotation_deg) << "\n";
  }
  return out.str();
}

}  // namespace mcvo
