#include "report_common.h"

#include <algorithm>
#include <cmath>

#include "mcvo/eval/report.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo::report_internal {
namespace {

using Json = nlohmann::ordered_json;

std::string JsonText(const Json& value) {
  if (value.is_string()) return value.get<std::string>();
  // Invalid UTF-8 in a user string must not throw: replace it.
  return value.dump(-1, ' ', false, Json::error_handler_t::replace);
}

void Flatten(const Json& value, const std::string& key, KeyValues* out) {
  if (value.is_object() && !value.empty()) {
    for (const auto& item : value.items()) {
      Flatten(item.value(), key.empty() ? item.key() : key + "." + item.key(), out);
    }
    return;
  }
  if (value.is_array() && !value.empty() &&
      std::any_of(value.begin(), value.end(), [](const Json& v) { return v.is_structured(); })) {
    for (size_t i = 0; i < value.size(); ++i) Flatten(value[i], key + "[" + std::to_string(i) + "]", out);
    return;
  }
  out->emplace_back(key.empty() ? "(value)" : key, JsonText(value));
}

std::string StatsLine(const ErrorStats& s, const char* unit) {
  if (s.count == 0) return "-";
  return StrCat(Fixed(s.mean, 4), " / ", Fixed(s.median, 4), " / ", Fixed(s.max, 4), " ", unit);
}

}  // namespace

std::string MdEscape(std::string_view text, bool escape_emphasis) {
  std::string out;
  out.reserve(text.size());
  for (const char ch : text) {
    switch (ch) {
      case '\n':
      case '\r':
      case '\t':
        out += ' ';
        break;
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '*':
      case '_':
      case '#':
        if (escape_emphasis) out += '\\';
        out += ch;
        break;
      case '\\':
      case '|':
      case '`':
      case '[':
      case ']':
        out += '\\';
        out += ch;
        break;
      default:
        if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f) {
          out += "\xEF\xBF\xBD";  // U+FFFD
        } else {
          out += ch;
        }
    }
  }
  return out;
}

std::string Fixed(double value, int decimals) { return FormatFixed(value, decimals); }

std::string StatOrDash(const ErrorStats& stats, double value, int decimals) {
  return stats.count > 0 ? Fixed(value, decimals) : "-";
}

std::string LengthText(double length_m) {
  if (std::abs(length_m - std::round(length_m)) < 1e-6) return FormatFixed(length_m, 0) + " m";
  return FormatFixed(length_m, std::abs(length_m) >= 10.0 ? 1 : 2) + " m";
}

const Trajectory& ReportEstimate(const ReportInputs& inputs) {
  if (inputs.estimate.poses.empty() && inputs.eval != nullptr) return inputs.eval->est_aligned;
  return inputs.estimate;
}

std::string CameraName(const ReportInputs& inputs, size_t camera) {
  if (camera < inputs.camera_names.size()) return inputs.camera_names[camera];
  return "camera " + std::to_string(camera);
}

size_t NumScaleCameras(const ReportInputs& inputs) {
  size_t n = inputs.camera_names.size();
  for (const ReportScaleEntry& e : inputs.scale_log) n = std::max(n, e.camera_scales.size());
  return n;
}

KeyValues SummaryRows(const ReportInputs& inputs) {
  KeyValues rows;
  const Trajectory& estimate = ReportEstimate(inputs);
  if (inputs.eval != nullptr) {
    const EvalResult& e = *inputs.eval;
    rows.emplace_back("estimate", e.est_name);
    rows.emplace_back("ground truth", e.gt_name);
    rows.emplace_back("poses", StrCat(e.num_est_poses, " estimated, ", e.num_gt_poses, " ground truth, ",
                                      e.association.pairs.size(), " matched"));
    std::string association(AssociationModeName(e.options.association.mode));
    if (e.options.association.mode == AssociationMode::kTime) {
      association += StrCat(" (max_dt ", FormatDouble(e.options.association.max_dt_s), " s, largest |dt| ",
                            FormatDouble(static_cast<double>(e.association.max_abs_dt_ns) * 1e-9), " s)");
    }
    rows.emplace_back("association", association);
    std::string alignment(AlignmentModeName(e.options.align));
    if (e.options.align != AlignmentMode::kNone) alignment += StrCat(" on ", e.num_alignment_poses, " poses");
    if (e.alignment_collinear) alignment += " (positions collinear)";
    rows.emplace_back("alignment", alignment);
    rows.emplace_back("ground-truth path (matched poses)", Fixed(e.gt_matched_path_length_m, 3) + " m");
    const ErrorStats& t = e.ate_translation_m;
    rows.emplace_back("ATE RMSE", t.count > 0 ? Fixed(t.rmse, 4) + " m" : "-");
    rows.emplace_back("ATE % of path", t.count > 0 && e.gt_matched_path_length_m > 0
                                           ? Fixed(100.0 * t.rmse / e.gt_matched_path_length_m, 4) + " %"
                                           : "-");
    rows.emplace_back("ATE mean / median / max", StatsLine(t, "m"));
    const ErrorStats& r = e.ate_rotation_deg;
    rows.emplace_back("ATE rotation RMSE", r.count > 0 ? Fixed(r.rmse, 4) + " deg" : "-");
    const RpeStepResult& step = e.rpe.step;
    if (step.translation_m.count > 0) {
      rows.emplace_back("RPE step (consecutive poses) RMSE", StrCat(Fixed(step.translation_m.rmse, 4), " m, ",
                                                                   Fixed(step.rotation_deg.rmse, 4), " deg over ",
                                                                   step.translation_m.count, " steps"));
    }
    const RpeAverage& avg = e.rpe.average;
    if (!e.rpe.computed) {
      rows.emplace_back("RPE", "skipped: " + e.rpe.skipped_reason);
    } else if (avg.num_lengths == 0) {
      rows.emplace_back("RPE", "no length has a segment");
    } else {
      rows.emplace_back(StrCat("RPE translation (mean of ", avg.num_lengths, " lengths)"),
                        Fixed(avg.translation_percent, 4) + " %");
      rows.emplace_back(StrCat("RPE rotation (mean of ", avg.num_lengths, " lengths)"),
                        Fixed(100.0 * avg.rotation_deg_per_m, 4) + " deg/100 m");
    }
    const ScaleResult& scale = e.scale;
    if (scale.available) {
      rows.emplace_back("scale error", StrCat(Fixed(scale.scale_error_percent, 3), " % (estimate ",
                                              Fixed(scale.est_scale_factor, 6), " x true size, Sim3 s ",
                                              Fixed(scale.sim3_scale, 6), ")"));
    } else {
      rows.emplace_back("scale error", "not available (" + scale.unavailable_reason + ")");
    }
    const LocalScaleResult& local = e.local_scale;
    if (local.ratio.count > 0) {
      rows.emplace_back(StrCat("local scale (", local.window_poses, "-pose windows)"),
                        StrCat(Fixed(local.ratio.min, 4), " to ", Fixed(local.ratio.max, 4), ", worst ",
                               Fixed(local.worst_deviation_percent, 2), " %, median ",
                               Fixed(local.median_deviation_percent, 2), " % over ", local.ratio.count,
                               " windows"));
    }
    const StartEndResult& se = e.start_end;
    const auto start_end = [](double distance, double path, const std::optional<double>& percent) {
      std::string text = Fixed(distance, 4) + " m";
      if (percent) text += StrCat(" (", Fixed(*percent, 3), " % of ", Fixed(path, 3), " m)");
      return text;
    };
    rows.emplace_back("start-end distance",
                      "estimate " + start_end(se.est_distance_m, se.est_path_length_m, se.est_percent) +
                          ", ground truth " +
                          start_end(se.gt_distance_m, se.gt_path_length_m, se.gt_percent));
  } else {
    rows.emplace_back("ground truth",
                      inputs.ground_truth.poses.empty()
                          ? "none: no errors are computed"
                          : StrCat(inputs.ground_truth.poses.size(), " poses (not evaluated)"));
    std::vector<Eigen::Vector3d> positions;
    for (const StampedPose& p : estimate.poses) positions.push_back(p.world_from_body.translation);
    rows.emplace_back("estimate",
                      StrCat(estimate.poses.size(), " poses, path ", Fixed(PathLength(positions), 3), " m"));
  }
  if (!inputs.scale_log.empty()) {
    size_t init = 0, reinit = 0, lost = 0, corrections = 0, applied = 0;
    for (const ReportScaleEntry& s : inputs.scale_log) {
      if (s.event == "init") {
        ++init;
      } else if (s.event == "reinit") {
        ++reinit;
      } else if (s.event == "lost") {
        ++lost;
      } else {
        ++corrections;
        if (s.applied) ++applied;
      }
    }
    rows.emplace_back("scale events", StrCat(init, " init, ", reinit, " reinit, ", lost, " lost, ",
                                             corrections, " corrections (", applied, " applied)"));
  }
  for (const auto& row : inputs.summary_rows) rows.push_back(row);
  return rows;
}

KeyValues FlattenSettings(const nlohmann::ordered_json& settings) {
  KeyValues out;
  if (settings.is_null()) return out;
  Flatten(settings, "", &out);
  return out;
}

KeyValues EvalOptionRows(const EvalResult& eval) {
  const Json j = Json::parse(EvalResultToJson(eval));
  return FlattenSettings(j["options"]);
}

Table AteTable(const EvalResult& eval) {
  Table table;
  table.header = {"ATE", "rmse", "mean", "median", "std", "min", "max", "count"};
  const auto row = [&table](const char* name, const ErrorStats& s) {
    table.rows.push_back({name, StatOrDash(s, s.rmse, 4), StatOrDash(s, s.mean, 4),
                          StatOrDash(s, s.median, 4), StatOrDash(s, s.std, 4), StatOrDash(s, s.min, 4),
                          StatOrDash(s, s.max, 4), std::to_string(s.count)});
  };
  row("translation (m)", eval.ate_translation_m);
  row("rotation (deg)", eval.ate_rotation_deg);
  return table;
}

Table RpeTable(const EvalResult& eval) {
  Table table;
  if (!eval.rpe.computed) return table;
  table.header = {"length",
                  "% of path",
                  "segments",
                  "trans mean (m)",
                  "trans mean (%)",
                  "trans max (%)",
                  "rot mean (deg/100 m)",
                  "rot max (deg/100 m)",
                  "est/gt distance",
                  "drift (Sim3-normalised)"};
  for (const RpeLengthResult& l : eval.rpe.lengths) {
    const ErrorStats& tp = l.translation_percent;
    const ErrorStats& rm = l.rotation_deg_per_m;
    table.rows.push_back({LengthText(l.length_m), l.length_percent ? FormatDouble(*l.length_percent) : "-",
                          std::to_string(l.translation_m.count),
                          StatOrDash(l.translation_m, l.translation_m.mean, 4), StatOrDash(tp, tp.mean, 4),
                          StatOrDash(tp, tp.max, 4), StatOrDash(rm, 100.0 * rm.mean, 4),
                          StatOrDash(rm, 100.0 * rm.max, 4), StatOrDash(l.scale_ratio, l.scale_ratio.mean, 6),
                          StatOrDash(l.scale_ratio_sim3_normalized, l.scale_ratio_sim3_normalized.mean, 6)});
  }
  const RpeAverage& avg = eval.rpe.average;
  if (avg.num_lengths > 0) {
    table.rows.push_back({StrCat("average (", avg.num_lengths, " lengths)"), "", "",
                          Fixed(avg.translation_m, 4), Fixed(avg.translation_percent, 4), "",
                          Fixed(100.0 * avg.rotation_deg_per_m, 4), "", "", ""});
  }
  return table;
}

Table ScaleLogTable(const ReportInputs& inputs, size_t* omitted) {
  Table table;
  const size_t num_cameras = NumScaleCameras(inputs);
  table.header = {"frame", "t (s)", "segment", "event", "applied"};
  for (size_t c = 0; c < num_cameras; ++c) table.header.push_back("scale " + CameraName(inputs, c));
  table.header.push_back("note");
  const size_t n = std::min(inputs.scale_log.size(), kMaxScaleLogRows);
  *omitted = inputs.scale_log.size() - n;
  for (size_t i = 0; i < n; ++i) {
    const ReportScaleEntry& e = inputs.scale_log[i];
    std::vector<std::string> row = {e.frame_index >= 0 ? std::to_string(e.frame_index) : "-",
                                    FormatNsAsSeconds(e.t_ns), std::to_string(e.segment), e.event,
                                    e.applied ? "yes" : "no"};
    for (size_t c = 0; c < num_cameras; ++c) {
      row.push_back(c < e.camera_scales.size() ? Fixed(e.camera_scales[c], 5) : "");
    }
    row.push_back(e.note);
    table.rows.push_back(std::move(row));
  }
  return table;
}

PathErrorSeries ErrorsAlongPath(const ReportInputs& inputs) {
  PathErrorSeries series;
  if (inputs.eval == nullptr) return series;
  const EvalResult& e = *inputs.eval;
  const Trajectory& gt = inputs.ground_truth;
  bool use_gt = gt.poses.size() == e.num_gt_poses;
  for (const PoseError& error : e.pose_errors) {
    if (error.gt_index >= gt.poses.size()) use_gt = false;
  }
  series.along_ground_truth = use_gt;
  double distance = 0.0;
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < e.pose_errors.size(); ++k) {
    const PoseError& error = e.pose_errors[k];
    Eigen::Vector3d position = Eigen::Vector3d::Constant(std::nan(""));
    if (use_gt) {
      position = gt.poses[error.gt_index].world_from_body.translation;
    } else if (error.est_index < e.est_aligned.poses.size()) {
      position = e.est_aligned.poses[error.est_index].world_from_body.translation;
    }
    if (k > 0 && position.allFinite() && previous.allFinite()) distance += (position - previous).norm();
    previous = position;
    series.distance_m.push_back(distance);
    series.translation_m.push_back(error.translation_m);
    series.rotation_deg.push_back(error.rotation_deg);
  }
  return series;
}

}  // namespace mcvo::report_internal
