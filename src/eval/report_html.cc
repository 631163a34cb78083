// report.html: one self-contained page. The plots are SVG drawn here
// (svg_plot.h); no script, no external resource. Layout in docs/eval.md,
// "Reports".
#include "mcvo/eval/report_html.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"
#include "report_common.h"
#include "svg_plot.h"

namespace mcvo {
namespace {

using report_internal::HtmlEscape;
using report_internal::KeyValues;
using report_internal::LegendEntry;
using report_internal::SvgPlot;
using report_internal::Table;

// Series colours: each used by one plot only, and apart from every other
// colour on the page by more than the browser test's tolerance (it counts
// their pixels in a screenshot).
constexpr const char* kGroundTruthColour = "#1a9850";
constexpr const char* kEstimateColour = "#d7301f";
constexpr const char* kBeforeLoopColour = "#7b3294";
constexpr const char* kTranslationColour = "#00008b";
constexpr const char* kRotationColour = "#b35806";
constexpr const char* kRpeFill = "#9ecae1";
constexpr const char* kRpeStroke = "#404040";
constexpr const char* kEventColour = "#555555";
constexpr const char* kLostColour = "#c51b7d";
constexpr std::array<const char*, 8> kCameraColours = {"#1f77b4", "#ff7f0e", "#9467bd", "#8c564b",
                                                       "#e377c2", "#17becf", "#bcbd22", "#7f7f7f"};

constexpr double kPlotWidth = 1000.0;
// Most scale markers drawn; beyond it only the applied corrections are marked.
constexpr size_t kMaxScaleMarkers = 3000;

constexpr const char* kStyle = R"css(
body { font-family: sans-serif; margin: 0; background: #f2f2f2; color: #111111; }
main { max-width: 1040px; margin: 0 auto; padding: 12px 20px 40px; background: #ffffff; }
h1 { font-size: 22px; margin: 8px 0 4px; }
h2 { font-size: 17px; margin: 22px 0 6px; border-bottom: 1px solid #dddddd; }
h3 { font-size: 14px; margin: 14px 0 4px; }
p.meta, p.caption { font-size: 12px; color: #444444; margin: 4px 0; }
table { border-collapse: collapse; font-size: 12px; margin: 6px 0; }
th, td { border: 1px solid #cccccc; padding: 2px 7px; text-align: left; vertical-align: top; }
th { background: #f0f0f0; }
table.numbers td { text-align: right; font-variant-numeric: tabular-nums; }
table.numbers td:first-child { text-align: left; }
ul.notes li { color: #8a4b00; font-size: 13px; }
div.row { display: flex; gap: 12px; flex-wrap: wrap; }
svg.plot { display: block; max-width: 100%; height: auto; }
)css";

std::string Heading(const char* tag, const std::string& id, const std::string& text) {
  return StrCat("<", tag, " id=\"", id, "\">", HtmlEscape(text), "</", tag, ">\n");
}

std::string Caption(const std::string& text) { return "<p class=\"caption\">" + HtmlEscape(text) + "</p>\n"; }

std::string KeyValueTable(const KeyValues& rows, const std::string& id) {
  std::string out = "<table class=\"kv\" id=\"" + id + "\">\n";
  for (const auto& [key, value] : rows) {
    out += "<tr><th>" + HtmlEscape(key) + "</th><td>" + HtmlEscape(value) + "</td></tr>\n";
  }
  return out + "</table>\n";
}

std::string TableHtml(const Table& table, const std::string& id) {
  std::string out = "<table class=\"numbers\" id=\"" + id + "\">\n<tr>";
  for (const std::string& h : table.header) out += "<th>" + HtmlEscape(h) + "</th>";
  out += "</tr>\n";
  for (const std::vector<std::string>& row : table.rows) {
    out += "<tr>";
    for (const std::string& cell : row) out += "<td>" + HtmlEscape(cell) + "</td>";
    out += "</tr>\n";
  }
  return out + "</table>\n";
}

std::vector<Eigen::Vector3d> Positions(const Trajectory& trajectory) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(trajectory.poses.size());
  for (const StampedPose& p : trajectory.poses) out.push_back(p.world_from_body.translation);
  return out;
}

// ---------------------------------------------------------------- trajectory

std::string TrajectorySection(const ReportInputs& inputs) {
  const Trajectory& estimate = report_internal::ReportEstimate(inputs);
  const std::vector<Eigen::Vector3d> gt = Positions(inputs.ground_truth);
  const std::vector<Eigen::Vector3d> est = Positions(estimate);
  const std::vector<Eigen::Vector3d> before = inputs.estimate_before_loop_closure
                                                  ? Positions(*inputs.estimate_before_loop_closure)
                                                  : std::vector<Eigen::Vector3d>();
  // The two axes with the most extent over everything drawn, in axis order.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto* series : {&gt, &est, &before}) {
    for (const Eigen::Vector3d& p : *series) {
      if (!p.allFinite()) continue;
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  const bool any = (hi.array() >= lo.array()).all();
  const Eigen::Vector3d extent = any ? Eigen::Vector3d(hi - lo) : Eigen::Vector3d::Zero();
  int drop = 2;  // the axis left out: the smallest extent (ties: the last axis)
  for (int i = 1; i >= 0; --i) {
    if (extent[i] < extent[drop]) drop = i;
  }
  const int a = drop == 0 ? 1 : 0, b = drop == 2 ? 1 : 2;
  const char* names[] = {"x", "y", "z"};

  std::string out =
      Heading("h2", "trajectory", StrCat("Trajectory, top-down (", names[a], "-", names[b], ")"));
  const double plot_w = kPlotWidth - 70.0 - 16.0;
  double area_h = 300.0;
  double x_lo = -1, x_hi = 1, y_lo = -1, y_hi = 1;
  if (any) {
    const double pad = std::max(0.04 * std::max(extent[a], extent[b]), 0.05);
    x_lo = lo[a] - pad;
    x_hi = hi[a] + pad;
    y_lo = lo[b] - pad;
    y_hi = hi[b] + pad;
    area_h = std::clamp(plot_w * (y_hi - y_lo) / (x_hi - x_lo), 260.0, 760.0);
  }
  SvgPlot plot("plot-trajectory", kPlotWidth, area_h + 14.0 + 46.0);
  plot.SetRanges(x_lo, x_hi, y_lo, y_hi, /*equal_aspect=*/true);
  plot.SetLabels(StrCat(names[a], " (m)"), StrCat(names[b], " (m)"));
  const auto project = [a, b](const std::vector<Eigen::Vector3d>& points) {
    std::vector<Eigen::Vector2d> out2;
    out2.reserve(points.size());
    for (const Eigen::Vector3d& p : points) out2.emplace_back(p[a], p[b]);
    return out2;
  };
  std::vector<LegendEntry> legend;
  if (!gt.empty()) {
    plot.AddPolyline(project(gt), "series-gt", kGroundTruthColour, 2.5);
    legend.push_back({"ground truth", kGroundTruthColour, LegendEntry::Kind::kLine});
  }
  if (!before.empty()) {
    plot.AddPolyline(project(before), "series-before-loop-closure", kBeforeLoopColour, 2.0, /*dashed=*/true);
    legend.push_back({inputs.before_label, kBeforeLoopColour, LegendEntry::Kind::kDashedLine});
  }
  if (!est.empty()) {
    plot.AddPolyline(project(est), "series-estimate", kEstimateColour, 2.0);
    legend.push_back({before.empty() ? "estimate" : "estimate (after loop closure)", kEstimateColour,
                      LegendEntry::Kind::kLine});
    plot.AddMarkers(project({est.front()}), "marker-start", "#000000", 5.0, true);
    plot.AddSquare(project({est.back()}).front(), "marker-end", "#000000", 4.5);
    legend.push_back({"start", "#000000", LegendEntry::Kind::kFilledMarker});
    legend.push_back({"end", "#000000", LegendEntry::Kind::kBox});
  }
  if (!any) plot.AddCentredText("no poses");
  plot.SetLegend(std::move(legend));
  out += plot.Render();
  std::string caption = "Equal aspect; one unit on both axes is the same length.";
  if (inputs.eval != nullptr) {
    caption += StrCat(" The estimate is aligned to the ground truth (",
                      AlignmentModeName(inputs.eval->options.align), ").");
  }
  return out + Caption(caption);
}

// ---------------------------------------------------------------- errors along the path

std::string ErrorPlot(const std::string& id, const std::vector<double>& x, const std::vector<double>& y,
                      double rmse, const char* colour, const std::string& x_label, const std::string& y_label,
                      const std::string& unit) {
  double x_max = 0.0, y_max = 0.0;
  std::vector<Eigen::Vector2d> points;
  for (size_t k = 0; k < x.size(); ++k) {
    points.emplace_back(x[k], y[k]);
    if (std::isfinite(x[k])) x_max = std::max(x_max, x[k]);
    if (std::isfinite(y[k])) y_max = std::max(y_max, y[k]);
  }
  SvgPlot plot(id, kPlotWidth, 250.0);
  plot.SetRanges(0.0, x_max > 0 ? x_max : 1.0, 0.0, y_max > 0 ? 1.08 * y_max : 1.0);
  plot.SetLabels(x_label, y_label);
  plot.AddPolyline(points, "series-error", colour, 1.5);
  plot.AddHorizontalLine(rmse, "rmse", "#000000", true, "RMSE " + FormatFixed(rmse, 4) + " " + unit);
  return plot.Render();
}

std::string ErrorSection(const ReportInputs& inputs) {
  std::string out = Heading("h2", "errors", "Absolute error along the path");
  const report_internal::PathErrorSeries series = report_internal::ErrorsAlongPath(inputs);
  if (series.distance_m.empty()) return out + Caption("No matched poses.");
  const std::string x_label = series.along_ground_truth ? "distance travelled along the ground truth (m)"
                                                        : "distance travelled along the aligned estimate (m)";
  out += ErrorPlot("plot-translation-error", series.distance_m, series.translation_m,
                   inputs.eval->ate_translation_m.rmse, kTranslationColour, x_label, "translation error (m)",
                   "m");
  out +=
      ErrorPlot("plot-rotation-error", series.distance_m, series.rotation_deg,
                inputs.eval->ate_rotation_deg.rmse, kRotationColour, x_label, "rotation error (deg)", "deg");
  return out + Caption("Per matched pose after alignment (ATE, docs/eval.md); dashed: RMSE.");
}

// ---------------------------------------------------------------- RPE

// Box: mean +- std (clipped to [min, max]); whiskers: min and max; thick
// line: median; circle: mean. The stats are those of eval.json.
std::string RpePlot(const std::string& id, const std::vector<RpeLengthResult>& lengths, bool translation) {
  const double factor = translation ? 1.0 : 100.0;  // rotation in deg/100 m
  std::vector<std::string> labels;
  double y_max = 0.0;
  for (const RpeLengthResult& l : lengths) {
    const ErrorStats& s = translation ? l.translation_percent : l.rotation_deg_per_m;
    labels.push_back(report_internal::LengthText(l.length_m) + (s.count == 0 ? " (none)" : ""));
    if (s.count > 0) y_max = std::max(y_max, factor * s.max);
  }
  SvgPlot plot(id, 494.0, 280.0);
  plot.SetMargins(62, 10, 14, 46);
  plot.SetRanges(0.0, 1.0, 0.0, y_max > 0 ? 1.08 * y_max : 1.0);  // the legend finds the emptiest corner
  plot.SetCategoricalX(labels);
  plot.SetLabels("segment length", translation ? "translation error (%)" : "rotation error (deg/100 m)");
  for (size_t i = 0; i < lengths.size(); ++i) {
    const ErrorStats& s = translation ? lengths[i].translation_percent : lengths[i].rotation_deg_per_m;
    if (s.count == 0) continue;
    const double x = static_cast<double>(i);
    const double mean = factor * s.mean, std_dev = factor * s.std, min = factor * s.min, max = factor * s.max;
    const double median = factor * s.median;
    plot.AddSegment({x, min}, {x, max}, "whisker", kRpeStroke, 1.2);
    plot.AddSegment({x - 0.12, min}, {x + 0.12, min}, "whisker", kRpeStroke, 1.2);
    plot.AddSegment({x - 0.12, max}, {x + 0.12, max}, "whisker", kRpeStroke, 1.2);
    const std::string unit = translation ? " %" : " deg/100 m";
    plot.AddRect(
        x - 0.25, std::max(min, mean - std_dev), x + 0.25, std::min(max, mean + std_dev), "box", kRpeFill,
        kRpeStroke,
        StrCat(report_internal::LengthText(lengths[i].length_m), ": ", s.count, " segments; mean ",
               FormatFixed(mean, 4), unit, ", std ", FormatFixed(std_dev, 4), ", median ",
               FormatFixed(median, 4), ", min ", FormatFixed(min, 4), ", max ", FormatFixed(max, 4)));
    plot.AddSegment({x - 0.25, median}, {x + 0.25, median}, "median", "#000000", 2.0);
    plot.AddMarkers({{x, mean}}, "mean", kRpeStroke, 3.0, false);
  }
  plot.SetLegend({{"mean +- std", kRpeFill, LegendEntry::Kind::kBox},
                  {"mean", kRpeStroke, LegendEntry::Kind::kHollowMarker},
                  {"median", "#000000", LegendEntry::Kind::kLine},
                  {"min / max", kRpeStroke, LegendEntry::Kind::kLine}});
  return plot.Render();
}

std::string RpeSection(const EvalResult& eval) {
  std::string out = Heading("h2", "rpe", "Relative pose error per segment length");
  if (!eval.rpe.computed) return out + Caption("RPE skipped: " + eval.rpe.skipped_reason);
  out += "<div class=\"row\">\n" + RpePlot("plot-rpe-translation", eval.rpe.lengths, true) +
         RpePlot("plot-rpe-rotation", eval.rpe.lengths, false) + "</div>\n";
  return out +
         Caption(
             "Every segment of each length (KITTI-style: errors divided by the nominal length). Box: mean +- "
             "std, clipped to the extremes; whiskers: min and max; black line: median.");
}

// ---------------------------------------------------------------- scale

std::string ScaleSection(const ReportInputs& inputs) {
  std::string out = Heading("h2", "scale", "Scale over time");
  const std::vector<ReportScaleEntry>& log = inputs.scale_log;
  // x: seconds since the first pose (or the first event), or the frame
  // index when the log has no time.
  bool use_frames = std::all_of(log.begin(), log.end(), [&log](const ReportScaleEntry& e) {
    return e.t_ns == log.front().t_ns && e.frame_index >= 0;
  });
  if (log.size() < 2) use_frames = false;
  const Trajectory& estimate = report_internal::ReportEstimate(inputs);
  const int64_t t0_ns = estimate.has_time && !estimate.poses.empty()
                            ? std::min(estimate.poses.front().t_ns, log.front().t_ns)
                            : log.front().t_ns;
  const auto x_of = [&](const ReportScaleEntry& e) {
    return use_frames ? static_cast<double>(e.frame_index) : static_cast<double>(e.t_ns - t0_ns) * 1e-9;
  };
  double x_lo = x_of(log.front()), x_hi = x_lo;
  for (const ReportScaleEntry& e : log) {
    x_lo = std::min(x_lo, x_of(e));
    x_hi = std::max(x_hi, x_of(e));
  }
  if (!use_frames && estimate.has_time && !estimate.poses.empty()) {
    x_lo = std::min(x_lo, 0.0);
    x_hi = std::max(x_hi, static_cast<double>(estimate.poses.back().t_ns - t0_ns) * 1e-9);
  }

  const size_t num_cameras = report_internal::NumScaleCameras(inputs);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> scale(num_cameras, nan);  // per camera, relative to the last initialisation
  std::vector<std::vector<Eigen::Vector2d>> lines(num_cameras);
  std::vector<std::vector<Eigen::Vector2d>> applied(num_cameras), not_applied(num_cameras);
  struct Event {
    double x;
    bool lost;
    std::string label;
  };
  std::vector<Event> events;
  for (const ReportScaleEntry& e : log) {
    const double x = x_of(e);
    if (e.event == "init" || e.event == "reinit" || e.event == "lost") {
      events.push_back({x, e.event == "lost", e.event});
      for (size_t c = 0; c < num_cameras; ++c) {
        if (std::isfinite(scale[c])) lines[c].emplace_back(x, scale[c]);
        lines[c].emplace_back(nan, nan);  // a new segment: break the line
        scale[c] = e.event == "lost" ? nan : 1.0;
        if (e.event != "lost") lines[c].emplace_back(x, 1.0);
      }
      continue;
    }
    for (size_t c = 0; c < num_cameras && c < e.camera_scales.size(); ++c) {
      const double ratio = e.camera_scales[c];
      if (!std::isfinite(ratio) || !(ratio > 0.0)) continue;
      if (!std::isfinite(scale[c])) {  // a correction without an init before it: start at 1
        scale[c] = 1.0;
        lines[c].emplace_back(x, 1.0);
      }
      const double proposed = scale[c] * ratio;
      (e.applied ? applied : not_applied)[c].emplace_back(x, proposed);
      if (e.applied) {
        lines[c].emplace_back(x, scale[c]);
        scale[c] = proposed;
        lines[c].emplace_back(x, scale[c]);
      }
    }
  }
  double y_lo = 1.0, y_hi = 1.0;
  for (size_t c = 0; c < num_cameras; ++c) {
    if (std::isfinite(scale[c])) lines[c].emplace_back(x_hi, scale[c]);
    for (const auto* points : {&lines[c], &applied[c], &not_applied[c]}) {
      for (const Eigen::Vector2d& p : *points) {
        if (!std::isfinite(p.y())) continue;
        y_lo = std::min(y_lo, p.y());
        y_hi = std::max(y_hi, p.y());
      }
    }
  }
  const double half = std::max(0.5 * (y_hi - y_lo) * 1.15, 0.01);
  const double y_mid = 0.5 * (y_lo + y_hi);
  size_t num_markers = 0;
  for (size_t c = 0; c < num_cameras; ++c) num_markers += applied[c].size() + not_applied[c].size();
  const bool mark_not_applied = num_markers <= kMaxScaleMarkers;
  std::vector<LegendEntry> legend;
  for (size_t c = 0; c < num_cameras; ++c) {
    legend.push_back({report_internal::CameraName(inputs, c), kCameraColours[c % kCameraColours.size()],
                      LegendEntry::Kind::kLine});
  }
  legend.push_back({"correction applied", "#333333", LegendEntry::Kind::kFilledMarker});
  if (mark_not_applied)
    legend.push_back({"correction not applied", "#333333", LegendEntry::Kind::kHollowMarker});
  legend.push_back({"init / reinit", kEventColour, LegendEntry::Kind::kLine});
  legend.push_back({"tracking lost", kLostColour, LegendEntry::Kind::kDashedLine});

  // The legend beside the plot: every line may run anywhere in it.
  SvgPlot plot("plot-scale", kPlotWidth,
               std::max(300.0, 14.0 + 46.0 + 17.0 * static_cast<double>(legend.size())));
  plot.SetLegend(std::move(legend), /*outside=*/true);
  plot.SetMargins(70, std::min(plot.LegendWidth() + 16.0, 0.4 * kPlotWidth), 14, 46);
  plot.SetRanges(x_lo, x_hi, y_mid - half, y_mid + half);
  plot.SetLabels(use_frames ? "frame" : "time since the first pose (s)",
                 "scale relative to the initialisation");
  const bool label_events = events.size() <= 30;
  for (const Event& event : events) {
    plot.AddVerticalLine(event.x, event.lost ? "event-lost" : "event-init",
                         event.lost ? kLostColour : kEventColour, event.lost,
                         label_events ? event.label : "");
  }
  for (size_t c = 0; c < num_cameras; ++c) {
    const char* colour = kCameraColours[c % kCameraColours.size()];
    plot.AddPolyline(lines[c], "series-scale", colour, 2.0);
    if (mark_not_applied) plot.AddMarkers(not_applied[c], "correction-not-applied", colour, 3.5, false);
    plot.AddMarkers(applied[c], "correction-applied", colour, 3.5, true);
  }
  out += plot.Render();
  std::string caption =
      "Per camera, the product of the applied scale-correction ratios since the last (re)initialisation. "
      "Markers: "
      "each correction's ratio (filled: applied, hollow: not applied, see the note in the scale log).";
  if (!mark_not_applied)
    caption += StrCat(" ", num_markers, " markers are too many: only applied ones are drawn.");
  return out + Caption(caption);
}

// ---------------------------------------------------------------- tables

std::string DetailSection(const ReportInputs& inputs) {
  std::string out;
  if (inputs.eval != nullptr) {
    out += Heading("h2", "details", "Error statistics");
    out += TableHtml(report_internal::AteTable(*inputs.eval), "table-ate");
    const Table rpe = report_internal::RpeTable(*inputs.eval);
    if (!rpe.rows.empty()) {
      out += TableHtml(rpe, "table-rpe");
      out += Caption(
          "RPE: means over the segments of each length; rotation per 100 m of nominal length. est/gt "
          "distance: "
          "estimated over true travelled distance, estimate unscaled (1 = metric).");
    }
  }
  if (!inputs.scale_log.empty()) {
    out += Heading("h2", "scale-log", "Scale log");
    size_t omitted = 0;
    out += TableHtml(report_internal::ScaleLogTable(inputs, &omitted), "table-scale-log");
    if (omitted > 0) out += Caption(StrCat(omitted, " more entries (scale_log.csv has them all)."));
  }
  const KeyValues settings = report_internal::FlattenSettings(inputs.settings);
  out += Heading("h2", "settings", "Settings");
  if (settings.empty() && inputs.eval == nullptr) out += Caption("None given.");
  if (!settings.empty()) out += KeyValueTable(settings, "table-settings");
  if (inputs.eval != nullptr) {
    out += Heading("h3", "eval-options", "Evaluation options");
    out += KeyValueTable(report_internal::EvalOptionRows(*inputs.eval), "table-eval-options");
  }
  return out;
}

}  // namespace

Trajectory ApplyAlignment(const Trajectory& estimate, const Sim3d& gt_world_from_est_world) {
  Trajectory out = estimate;
  for (StampedPose& pose : out.poses)
    pose.world_from_body = gt_world_from_est_world.TransformPose(pose.world_from_body);
  return out;
}

std::string RenderReportHtml(const ReportInputs& inputs) {
  const std::string title = inputs.title.empty() ? std::string("mcvo report") : inputs.title;
  std::string out = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  out += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  out += "<title>" + HtmlEscape(title) + "</title>\n<style>" + kStyle + "</style>\n</head>\n<body>\n<main>\n";
  out += Heading("h1", "title", title);
  out +=
      "<p class=\"meta\">mcvo evaluation report. Self-contained: the plots are inline SVG, nothing is loaded "
      "from elsewhere. The same numbers in Markdown: report.md.</p>\n";
  if (inputs.eval != nullptr && !inputs.eval->notes.empty()) {
    out += "<ul class=\"notes\" id=\"notes\">\n";
    for (const std::string& note : inputs.eval->notes) out += "<li>" + HtmlEscape(note) + "</li>\n";
    out += "</ul>\n";
  }
  out += Heading("h2", "summary", "Summary");
  out += KeyValueTable(report_internal::SummaryRows(inputs), "table-summary");
  out += TrajectorySection(inputs);
  if (inputs.eval != nullptr) {
    out += ErrorSection(inputs);
    out += RpeSection(*inputs.eval);
  } else {
    out += Heading("h2", "errors", "Errors");
    out += Caption("No ground truth: no errors, RPE or scale error.");
  }
  if (!inputs.scale_log.empty()) out += ScaleSection(inputs);
  out += DetailSection(inputs);
  out += "</main>\n</body>\n</html>\n";
  return out;
}

void WriteReports(const std::filesystem::path& dir, const ReportInputs& inputs) {
  const std::string html = RenderReportHtml(inputs);
  const std::string markdown = RenderReportMarkdown(inputs);
  CreateDirectories(dir);
  WriteFileAtomic(dir / "report.html", html);
  WriteFileAtomic(dir / "report.md", markdown);
}

}  // namespace mcvo
