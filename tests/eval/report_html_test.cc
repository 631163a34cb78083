// report.html / report.md (eval/report_html.h): the rendered strings, and
// Chromium's rendering of the page (skipped without /usr/bin/chromium).
#include "mcvo/eval/report_html.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "eval/trajectory_fixtures.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;
using testing::MakeTrajectory;

// ---------------------------------------------------------------- fixtures

// A figure eight of about 200 x 120 m in the x-y plane (z climbs a little).
Rigid3d EightPose(int k, int n) {
  const double a = 2.0 * testing::kPi * k / n;
  const Eigen::Vector3d position(100.0 * std::sin(a), 60.0 * std::sin(2.0 * a), 0.002 * k);
  return Rigid3d(So3Exp(Eigen::Vector3d(0.0, 0.0, a)), position);
}

// Deterministic, irregular wiggle in [-1, 1].
double Wiggle(int k) { return std::sin(0.37 * k) * std::cos(0.011 * k * k + 0.5); }

// An evaluated run: ground truth, an estimate 5 % too large with a wiggle,
// a "before loop closure" version that drifts, a scale log of every event
// kind, and settings. The ReportInputs point into this object.
struct Example {
  Trajectory gt;
  Trajectory est;
  EvalResult eval;
  ReportInputs inputs;
};

std::unique_ptr<Example> MakeExample(int n = 400) {
  auto example = std::make_unique<Example>();
  example->gt = MakeTrajectory(n, [n](int k) { return EightPose(k, n); });
  example->est = testing::Transformed(
      example->gt, Rigid3d(So3Exp(Eigen::Vector3d(0.0, 0.0, 0.4)), Eigen::Vector3d(5, -3, 1)), 1.05);
  for (int k = 0; k < n; ++k) {
    Rigid3d& pose = example->est.poses[k].world_from_body;
    pose.translation.x() += 0.8 * Wiggle(k);
    pose.rotation = pose.rotation * So3Exp(Eigen::Vector3d(0.01 * Wiggle(k + 3), 0.0, 0.02 * Wiggle(k + 11)));
  }
  example->eval = EvaluateTrajectory(example->gt, example->est, EvalOptions(), "gt.tum", "est.tum");

  Trajectory before = example->est;
  for (int k = 0; k < n; ++k) before.poses[k].world_from_body.translation.y() += 0.05 * k;
  ReportInputs& in = example->inputs;
  in.title = "figure eight";
  in.eval = &example->eval;
  in.ground_truth = example->gt;
  in.estimate_before_loop_closure = ApplyAlignment(before, example->eval.gt_world_from_est_world);
  const int64_t t0 = example->gt.poses.front().t_ns;
  const int64_t dt = 100000000;
  in.scale_log = {
      {0, t0, 0, "init", {0.8, 0.9, 1.1}, true, "scale from rig rotation"},
      {10, t0 + 10 * dt, 0, "correction", {1.04, 0.97, 1.0}, true, "applied to landmark inverse depths"},
      {60, t0 + 60 * dt, 0, "correction", {1.0, 1.0, 1.0}, false, "not applied: not observable"},
      {90, t0 + 90 * dt, 0, "correction", {1.01, 1.002, 0.999}, false, "not applied: every change below"},
      {150, t0 + 150 * dt, 1, "lost", {}, false, "tracking lost: 3 inliers"},
      {170, t0 + 170 * dt, 1, "reinit", {0.7, 0.8, 1.2}, true, "scale from cross-camera baseline"},
      {250, t0 + 250 * dt, 1, "correction", {0.96, 1.0, 1.03}, true, "applied to landmark inverse depths"},
  };
  in.camera_names = {"front", "left", "right"};
  in.settings = nlohmann::ordered_json::parse(R"({"backend": {"window_size": 10, "huber": 1.5},
      "cameras": [{"name": "front"}, {"name": "left"}], "lengths": [1, 2], "dataset": "synth"})");
  in.summary_rows = {{"version", "0.1.0"}, {"posed frames", "400 / 400"}};
  return example;
}

// ---------------------------------------------------------------- string helpers

size_t Count(const std::string& text, const std::string& what) {
  size_t count = 0;
  for (size_t pos = text.find(what); pos != std::string::npos; pos = text.find(what, pos + what.size()))
    ++count;
  return count;
}

bool Contains(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

// The <svg id="id"> ... </svg> element; empty when there is none.
std::string Svg(const std::string& html, const std::string& id) {
  const size_t begin = html.find("<svg id=\"" + id + "\"");
  if (begin == std::string::npos) return {};
  const size_t end = html.find("</svg>", begin);
  return html.substr(begin, end == std::string::npos ? std::string::npos : end + 6 - begin);
}

// The d attribute of every <path class="css_class" ...> in `svg`.
std::vector<std::string> PathData(const std::string& svg, const std::string& css_class) {
  std::vector<std::string> data;
  const std::string key = "<path class=\"" + css_class + "\" d=\"";
  for (size_t pos = svg.find(key); pos != std::string::npos; pos = svg.find(key, pos + 1)) {
    const size_t begin = pos + key.size();
    data.push_back(svg.substr(begin, svg.find('"', begin) - begin));
  }
  return data;
}

// The points of every such path, one vector per path.
std::vector<std::vector<Eigen::Vector2d>> Paths(const std::string& svg, const std::string& css_class) {
  std::vector<std::vector<Eigen::Vector2d>> paths;
  for (const std::string& d : PathData(svg, css_class)) {
    std::vector<Eigen::Vector2d> points;
    for (std::string_view item : SplitTokens(d, "ML")) {
      const std::vector<std::string_view> xy = SplitFields(item.substr(0, item.find('h')), ',');
      if (xy.size() != 2) continue;
      points.emplace_back(ParseDouble(xy[0]).value_or(NAN), ParseDouble(xy[1]).value_or(NAN));
    }
    paths.push_back(points);
  }
  return paths;
}

size_t NumPoints(const std::vector<std::vector<Eigen::Vector2d>>& paths) {
  size_t n = 0;
  for (const auto& path : paths) n += path.size();
  return n;
}

// ---------------------------------------------------------------- rendered strings

TEST(ReportHtml, EveryPlotIsDrawnWithItsSeries) {
  const auto example = MakeExample();
  const std::string html = RenderReportHtml(example->inputs);
  ASSERT_EQ(html.rfind("<!DOCTYPE html>\n", 0), 0u);
  ASSERT_GE(html.size(), 8u);
  EXPECT_EQ(html.substr(html.size() - 8), "</html>\n");
  for (const char* id : {"plot-trajectory", "plot-translation-error", "plot-rotation-error",
                         "plot-rpe-translation", "plot-rpe-rotation", "plot-scale"}) {
    EXPECT_EQ(Count(html, std::string("<svg id=\"") + id + "\""), 1u) << id;
  }
  const std::string trajectory = Svg(html, "plot-trajectory");
  EXPECT_GT(NumPoints(Paths(trajectory, "series-gt")), 50u);
  EXPECT_GT(NumPoints(Paths(trajectory, "series-estimate")), 50u);
  EXPECT_GT(NumPoints(Paths(trajectory, "series-before-loop-closure")), 50u);
  EXPECT_TRUE(Contains(trajectory, ">ground truth</text>"));
  EXPECT_TRUE(Contains(trajectory, ">before loop closure</text>"));
  EXPECT_TRUE(Contains(trajectory, ">estimate (after loop closure)</text>"));
  EXPECT_TRUE(Contains(html, "Trajectory, top-down (x-y)"));
  EXPECT_TRUE(Contains(trajectory, ">x (m)</text>"));
  // Metre ticks along both axes (the eight spans about -100..100 m in x).
  EXPECT_TRUE(Contains(trajectory, ">-100</text>") || Contains(trajectory, ">-80</text>"));
  // One error point per matched pose (400 < the decimation bound, but
  // points that do not move the pen may be dropped).
  const auto translation = Paths(Svg(html, "plot-translation-error"), "series-error");
  ASSERT_EQ(translation.size(), 1u);
  EXPECT_GT(translation[0].size(), 100u);
  EXPECT_LE(translation[0].size(), 400u);
  EXPECT_EQ(Paths(Svg(html, "plot-rotation-error"), "series-error").size(), 1u);
  EXPECT_TRUE(Contains(Svg(html, "plot-translation-error"),
                       "RMSE " + FormatFixed(example->eval.ate_translation_m.rmse, 4) + " m"));
  // One box per RPE length, in both RPE plots.
  const size_t lengths = example->eval.rpe.lengths.size();
  EXPECT_EQ(Count(Svg(html, "plot-rpe-translation"), "<rect class=\"box\""), lengths);
  EXPECT_EQ(Count(Svg(html, "plot-rpe-rotation"), "<rect class=\"box\""), lengths);
  // The summary carries the evaluation's numbers.
  EXPECT_TRUE(
      Contains(html, "<th>ATE RMSE</th><td>" + FormatFixed(example->eval.ate_translation_m.rmse, 4) + " m"));
  EXPECT_TRUE(
      Contains(html, "<th>scale error</th><td>" + FormatFixed(example->eval.scale.scale_error_percent, 3)));
  EXPECT_TRUE(Contains(html, "<th>version</th><td>0.1.0</td>"));
  // Settings flattened.
  EXPECT_TRUE(Contains(html, "<th>backend.window_size</th><td>10</td>"));
  EXPECT_TRUE(Contains(html, "<th>cameras[1].name</th><td>left</td>"));
  EXPECT_TRUE(Contains(html, "<th>lengths</th><td>[1,2]</td>"));
  EXPECT_TRUE(Contains(html, "<th>align</th><td>se3</td>"));  // the eval options
}

TEST(ReportHtml, IsSelfContained) {
  const auto example = MakeExample();
  const std::string html = RenderReportHtml(example->inputs);
  EXPECT_FALSE(Contains(html, "<script"));
  EXPECT_FALSE(Contains(html, "<link"));
  EXPECT_FALSE(Contains(html, "<img"));
  EXPECT_FALSE(Contains(html, "src="));
  EXPECT_FALSE(Contains(html, "href="));
  EXPECT_FALSE(Contains(html, "@import"));
  // The only URL is the SVG namespace name (not fetched), the only url() a local clip path.
  EXPECT_EQ(Count(html, "http"), Count(html, "xmlns=\"http://www.w3.org/2000/svg\""));
  EXPECT_EQ(Count(html, "url("), Count(html, "url(#clip-plot-"));
}

TEST(ReportHtml, EscapesUserText) {
  auto example = MakeExample();
  ReportInputs& in = example->inputs;
  in.title = "<script>alert('x')</script> & \"q\"";
  in.camera_names = {"fr<b>ont", "left & right", "a|b"};
  in.summary_rows.push_back({"<i>key</i>", "value <b>bold</b>"});
  in.settings["path"] = "/data/<seq>&\"1\"";
  in.scale_log[1].note = "note <img src=x onerror=alert(1)>";
  in.scale_log[2].note = std::string("bell\x07") + "\n";
  const std::string html = RenderReportHtml(in);
  EXPECT_FALSE(Contains(html, "<script>"));
  EXPECT_FALSE(Contains(html, "<b>"));
  EXPECT_FALSE(Contains(html, "<i>"));
  EXPECT_FALSE(Contains(html, "<img"));
  EXPECT_FALSE(Contains(html, "\x07"));
  EXPECT_TRUE(
      Contains(html, "<title>&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; &quot;q&quot;</title>"));
  EXPECT_TRUE(Contains(html, "fr&lt;b&gt;ont"));
  EXPECT_TRUE(Contains(html, "left &amp; right"));
  EXPECT_TRUE(Contains(html, "<th>&lt;i&gt;key&lt;/i&gt;</th><td>value &lt;b&gt;bold&lt;/b&gt;</td>"));
  EXPECT_TRUE(Contains(html, "/data/&lt;seq&gt;&amp;&quot;1&quot;"));
  EXPECT_TRUE(Contains(html, "note &lt;img src=x onerror=alert(1)&gt;"));

  const std::string md = RenderReportMarkdown(in);
  EXPECT_EQ(md.rfind("# &lt;script&gt;alert('x')&lt;/script&gt; &amp; \"q\"\n", 0), 0u) << md.substr(0, 120);
  EXPECT_TRUE(Contains(md, "scale a\\|b"));
  EXPECT_FALSE(Contains(md, "<b>"));
  // Every line of the scale-log table has as many cells as its header: the
  // pipe in a name and the newline in a note do not break the table.
  const size_t header = md.find("| frame |");
  ASSERT_NE(header, std::string::npos);
  const auto cells = [](const std::string& line) { return Count(line, "|") - Count(line, "\\|"); };
  const std::string header_line = md.substr(header, md.find('\n', header) - header);
  size_t pos = header;
  for (int row = 0; row < 2 + static_cast<int>(in.scale_log.size()); ++row) {
    const size_t end = md.find('\n', pos);
    EXPECT_EQ(cells(md.substr(pos, end - pos)), cells(header_line)) << md.substr(pos, end - pos);
    pos = end + 1;
  }
}

TEST(ReportHtml, SameInputsGiveSameBytes) {
  const auto a = MakeExample();
  const auto b = MakeExample();
  const std::string html = RenderReportHtml(a->inputs);
  EXPECT_EQ(html, RenderReportHtml(a->inputs));
  EXPECT_EQ(html, RenderReportHtml(b->inputs));
  EXPECT_EQ(RenderReportMarkdown(a->inputs), RenderReportMarkdown(b->inputs));
  // And the input matters: one pose moved changes the page.
  b->inputs.ground_truth.poses[10].world_from_body.translation.x() += 1.0;
  EXPECT_NE(html, RenderReportHtml(b->inputs));
}

TEST(ReportHtml, WithoutGroundTruthDrawsTheTrajectoryOnly) {
  const auto example = MakeExample();
  ReportInputs in;
  in.title = "no gt";
  in.estimate = example->est;
  in.scale_log = example->inputs.scale_log;
  const std::string html = RenderReportHtml(in);
  const std::string trajectory = Svg(html, "plot-trajectory");
  EXPECT_GT(NumPoints(Paths(trajectory, "series-estimate")), 50u);
  EXPECT_TRUE(Paths(trajectory, "series-gt").empty());
  EXPECT_TRUE(Svg(html, "plot-translation-error").empty());
  EXPECT_TRUE(Svg(html, "plot-rpe-translation").empty());
  EXPECT_FALSE(Svg(html, "plot-scale").empty());
  EXPECT_TRUE(Contains(html, "No ground truth"));
  EXPECT_TRUE(Contains(html, "<th>ground truth</th><td>none: no errors are computed</td>"));
  const std::string md = RenderReportMarkdown(in);
  EXPECT_TRUE(Contains(md, "No ground truth"));
  EXPECT_FALSE(Contains(md, "## Error statistics"));
  EXPECT_TRUE(Contains(md, "## Scale log"));
}

TEST(ReportHtml, EvalWithoutGroundTruthPosesMeasuresAlongTheEstimate) {
  auto example = MakeExample();
  example->inputs.ground_truth = Trajectory();
  const std::string html = RenderReportHtml(example->inputs);
  const std::string errors = Svg(html, "plot-translation-error");
  EXPECT_TRUE(Contains(errors, ">distance travelled along the aligned estimate (m)</text>"));
  EXPECT_EQ(Paths(errors, "series-error").size(), 1u);
  EXPECT_TRUE(Paths(Svg(html, "plot-trajectory"), "series-gt").empty());
  // With the ground truth, along the ground truth.
  EXPECT_TRUE(Contains(RenderReportHtml(MakeExample()->inputs),
                       ">distance travelled along the ground truth (m)</text>"));
}

TEST(ReportHtml, EmptyInputsGiveAValidPage) {
  const ReportInputs in;
  const std::string html = RenderReportHtml(in);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_TRUE(Contains(html, "<title>mcvo report</title>"));
  EXPECT_TRUE(Contains(Svg(html, "plot-trajectory"), ">no poses</text>"));
  EXPECT_TRUE(Svg(html, "plot-scale").empty());
  EXPECT_FALSE(Contains(html, "nan"));
  EXPECT_FALSE(Contains(html, "inf"));
  const std::string md = RenderReportMarkdown(in);
  EXPECT_EQ(md.rfind("# mcvo report\n", 0), 0u);
  EXPECT_TRUE(Contains(md, "None given."));
  // A single pose: no extent, still finite coordinates.
  ReportInputs one;
  one.estimate = MakeTrajectory(1, [](int) { return Rigid3d(); });
  const std::string single = RenderReportHtml(one);
  EXPECT_EQ(Paths(Svg(single, "plot-trajectory"), "series-estimate").size(), 1u);
  EXPECT_FALSE(Contains(single, "nan"));
}

TEST(ReportHtml, LongRunsAreDecimated) {
  // 10k poses, noisy at every pose: without decimation 10k points per line.
  const int n = 10000;
  const Trajectory gt = MakeTrajectory(n, [n](int k) { return EightPose(k, n); });
  Trajectory est = gt;
  for (int k = 0; k < n; ++k) {
    Rigid3d& pose = est.poses[k].world_from_body;
    pose.translation += Eigen::Vector3d(0.3 * Wiggle(k), 0.3 * Wiggle(k + 7), 0.0);
    pose.rotation = pose.rotation * So3Exp(Eigen::Vector3d(0.0, 0.01 * Wiggle(k + 5), 0.0));
  }
  const EvalResult eval = EvaluateTrajectory(gt, est, EvalOptions());
  ReportInputs in;
  in.eval = &eval;
  in.ground_truth = gt;
  in.estimate_before_loop_closure = eval.est_aligned;
  const std::string html = RenderReportHtml(in);
  for (const char* id : {"plot-trajectory", "plot-translation-error", "plot-rotation-error"}) {
    const std::string svg = Svg(html, id);
    for (const char* series :
         {"series-gt", "series-estimate", "series-before-loop-closure", "series-error"}) {
      for (const auto& path : Paths(svg, series)) {
        EXPECT_LE(path.size(), 2000u) << id << " " << series;
        EXPECT_GT(path.size(), 50u) << id << " " << series;  // decimated, not gutted
      }
    }
  }
  EXPECT_EQ(Paths(Svg(html, "plot-translation-error"), "series-error").size(), 1u);
  EXPECT_LT(html.size(), 400u * 1024u) << html.size();
  std::printf("10k poses: report.html %zu bytes\n", html.size());
}

TEST(ReportHtml, DecimationKeepsSpikes) {
  // One pose far off among 10k: the error plot must still reach its peak.
  const int n = 10000;
  const Trajectory gt = MakeTrajectory(n, [n](int k) { return EightPose(k, n); });
  Trajectory est = gt;
  for (int k = 0; k < n; ++k) est.poses[k].world_from_body.translation.z() += 0.05 * Wiggle(k);
  est.poses[6543].world_from_body.translation.z() += 3.0;
  EvalOptions options;
  options.align = AlignmentMode::kNone;
  const EvalResult eval = EvaluateTrajectory(gt, est, options);
  ReportInputs in;
  in.eval = &eval;
  in.ground_truth = gt;
  const auto paths = Paths(Svg(RenderReportHtml(in), "plot-translation-error"), "series-error");
  ASSERT_EQ(paths.size(), 1u);
  // The y range is [0, 1.08 max] over the 190 px high area starting at y = 14,
  // so the maximum lies at 14 + 190 * 0.08 / 1.08.
  double top = 1e9;
  for (const Eigen::Vector2d& p : paths[0]) top = std::min(top, p.y());
  EXPECT_NEAR(top, 14.0 + 190.0 * 0.08 / 1.08, 0.1);
}

TEST(ReportHtml, ScalePlotShowsCorrectionsAndEvents) {
  const auto example = MakeExample();
  const std::string scale = Svg(RenderReportHtml(example->inputs), "plot-scale");
  ASSERT_FALSE(scale.empty());
  // Applied: 2 corrections x 3 cameras; not applied: 2 x 3.
  EXPECT_EQ(Count(scale, "<circle class=\"correction-applied\""), 6u);
  EXPECT_EQ(Count(scale, "<circle class=\"correction-not-applied\""), 6u);
  EXPECT_EQ(Count(scale, "<line class=\"event-init\""), 2u);  // init, reinit
  EXPECT_EQ(Count(scale, "<line class=\"event-lost\""), 1u);
  for (const char* label :
       {">front</text>", ">left</text>", ">right</text>", ">lost</text>", ">reinit</text>"}) {
    EXPECT_TRUE(Contains(scale, label)) << label;
  }
  // One line per camera, broken at the loss (two runs: two moveto's each).
  const auto lines = Paths(scale, "series-scale");
  ASSERT_EQ(lines.size(), 3u);
  for (const std::string& d : PathData(scale, "series-scale")) EXPECT_EQ(Count(d, "M"), 2u) << d;
  // The front camera's applied ratio 1.04 lifts its line above 1: with the
  // range padded about [0.96, 1.04], the highest point is above the middle.
  double top = 1e9, bottom = -1e9;
  for (const Eigen::Vector2d& p : lines[0]) {
    top = std::min(top, p.y());
    bottom = std::max(bottom, p.y());
  }
  EXPECT_LT(top, 14.0 + 0.5 * 240.0 - 20.0);
  EXPECT_GT(bottom, 14.0 + 0.5 * 240.0 + 20.0);  // 0.96 after the reinit
  // Time axis from the first pose.
  EXPECT_TRUE(Contains(scale, ">time since the first pose (s)</text>"));
}

TEST(ReportHtml, TopDownUsesTheTwoAxesWithMostExtent) {
  // A drive in the x-z plane (KITTI camera frame: y down).
  ReportInputs in;
  in.estimate = MakeTrajectory(100, [](int k) {
    return Rigid3d(Eigen::Quaterniond::Identity(),
                   Eigen::Vector3d(0.5 * k, 0.01 * std::sin(0.1 * k), 20 * std::sin(0.05 * k)));
  });
  const std::string html = RenderReportHtml(in);
  EXPECT_TRUE(Contains(html, "Trajectory, top-down (x-z)"));
  EXPECT_TRUE(Contains(Svg(html, "plot-trajectory"), ">z (m)</text>"));
}

TEST(ReportHtml, ApplyAlignmentMatchesTheEvaluation) {
  const auto example = MakeExample(50);
  const Trajectory aligned = ApplyAlignment(example->est, example->eval.gt_world_from_est_world);
  ASSERT_EQ(aligned.poses.size(), example->eval.est_aligned.poses.size());
  for (size_t k = 0; k < aligned.poses.size(); ++k) {
    EXPECT_EQ(aligned.poses[k].t_ns, example->eval.est_aligned.poses[k].t_ns);
    EXPECT_LT((aligned.poses[k].world_from_body.translation -
               example->eval.est_aligned.poses[k].world_from_body.translation)
                  .norm(),
              1e-9);
  }
}

TEST(ReportMarkdown, SameNumbersAsTheEvaluation) {
  const auto example = MakeExample();
  const std::string md = RenderReportMarkdown(example->inputs);
  EXPECT_EQ(md.rfind("# figure eight\n", 0), 0u);
  EXPECT_TRUE(Contains(md, "report.html"));
  EXPECT_TRUE(Contains(md, "| ATE RMSE | " + FormatFixed(example->eval.ate_translation_m.rmse, 4) + " m |"));
  EXPECT_TRUE(Contains(md, "| RPE translation (mean of 5 lengths) | " +
                               FormatFixed(example->eval.rpe.average.translation_percent, 4) + " % |"));
  EXPECT_TRUE(Contains(md, "| version | 0.1.0 |"));
  EXPECT_TRUE(Contains(md, "| backend.window\\_size | 10 |"));
  // One RPE row per length plus the average.
  EXPECT_EQ(Count(md, "| length | % of path |"), 1u);
  const size_t rpe = md.find("| length |");
  ASSERT_NE(rpe, std::string::npos);
  const size_t end = md.find("\n\n", rpe);
  EXPECT_EQ(Count(md.substr(rpe, end - rpe), "\n"), 1 + 1 + example->eval.rpe.lengths.size());
  EXPECT_EQ(Count(md, "| correction |"), 4u);
  EXPECT_EQ(md.back(), '\n');
  EXPECT_NE(md.substr(md.size() - 2), "\n\n");
}

fs::path ProcessTempDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / StrCat("mcvo_report_", name, "_", ::getpid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(ReportFiles, WriteReportsWritesBothFiles) {
  const fs::path dir = ProcessTempDir("write");
  const auto example = MakeExample(100);
  WriteReports(dir / "sub", example->inputs);
  EXPECT_EQ(ReadFileToString(dir / "sub" / "report.html"), RenderReportHtml(example->inputs));
  EXPECT_EQ(ReadFileToString(dir / "sub" / "report.md"), RenderReportMarkdown(example->inputs));
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir / "sub")) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 2u);  // no temporary left behind
  fs::remove_all(dir);
}

// ---------------------------------------------------------------- in a browser

constexpr const char* kChromium = "/usr/bin/chromium";

int RunShell(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Headless Chromium's screenshot of `html` (1200 x 3000); empty on failure.
cv::Mat Screenshot(const fs::path& dir, const fs::path& html, const std::string& tag) {
  const fs::path png = dir / (tag + ".png");
  const std::string command = StrCat(
      "timeout 60 ", kChromium, " --headless --no-sandbox --disable-gpu --hide-scrollbars --user-data-dir=\"",
      (dir / ("profile-" + tag)).string(), "\" --screenshot=\"", png.string(),
      "\" --window-size=1200,3000 \"file://", html.string(), "\" > \"", (dir / (tag + ".log")).string(),
      "\" 2>&1");
  if (RunShell(command) != 0 || !fs::exists(png)) return cv::Mat();
  return cv::imread(png.string(), cv::IMREAD_COLOR);
}

// Pixels within `tolerance` (per channel) of the colour "#rrggbb".
int CountColour(const cv::Mat& bgr, const std::string& hex, int tolerance = 24) {
  const int r = std::stoi(hex.substr(1, 2), nullptr, 16), g = std::stoi(hex.substr(3, 2), nullptr, 16),
            b = std::stoi(hex.substr(5, 2), nullptr, 16);
  int count = 0;
  for (int y = 0; y < bgr.rows; ++y) {
    const cv::Vec3b* row = bgr.ptr<cv::Vec3b>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      if (std::abs(row[x][2] - r) <= tolerance && std::abs(row[x][1] - g) <= tolerance &&
          std::abs(row[x][0] - b) <= tolerance) {
        ++count;
      }
    }
  }
  return count;
}

// Chromium renders the page and the plots are really drawn: each plot's
// stroke colour covers many pixels of the screenshot. The same page with the
// path data removed (legends, frames and tables intact) must NOT pass, which
// shows the check sees the plots themselves.
TEST(ReportBrowser, ChromiumDrawsThePlots) {
  if (!fs::exists(kChromium)) GTEST_SKIP() << kChromium << " not found: the browser test needs Chromium";
  const fs::path dir = ProcessTempDir("browser");
  const auto example = MakeExample();
  const std::string html = RenderReportHtml(example->inputs);
  WriteFileAtomic(dir / "report.html", html);
  std::string broken = html;
  for (size_t pos = broken.find(" d=\""); pos != std::string::npos; pos = broken.find(" d=\"", pos + 8)) {
    broken.replace(pos, 4, " data-d=\"");
  }
  WriteFileAtomic(dir / "broken.html", broken);

  // The page parses into the six plots, with their path data.
  ASSERT_EQ(RunShell(StrCat(
                "timeout 60 ", kChromium, " --headless --no-sandbox --disable-gpu --user-data-dir=\"",
                (dir / "profile-dom").string(), "\" --dump-dom \"file://", (dir / "report.html").string(),
                "\" > \"", (dir / "dom.html").string(), "\" 2> \"", (dir / "dom.log").string(), "\"")),
            0)
      << ReadFileToString(dir / "dom.log");
  const std::string dom = ReadFileToString(dir / "dom.html");
  EXPECT_EQ(Count(dom, "<svg id=\"plot-"), 6u);
  EXPECT_EQ(Count(dom, "<path class=\"series-estimate\" d=\"M"), 1u);

  const cv::Mat good = Screenshot(dir, dir / "report.html", "good");
  ASSERT_FALSE(good.empty()) << ReadFileToString(dir / "good.log");
  ASSERT_EQ(good.cols, 1200);
  ASSERT_EQ(good.rows, 3000);
  const cv::Mat bad = Screenshot(dir, dir / "broken.html", "broken");
  ASSERT_FALSE(bad.empty()) << ReadFileToString(dir / "broken.log");

  // Stroke colours of: ground truth, estimate, before loop closure,
  // translation error, rotation error, the first camera's scale.
  constexpr int kMinPixels = 600;  // a legend swatch is < 100
  for (const char* colour : {"#1a9850", "#d7301f", "#7b3294", "#00008b", "#b35806", "#1f77b4"}) {
    const int drawn = CountColour(good, colour), without_paths = CountColour(bad, colour);
    std::printf("%s: %d pixels, %d without the paths\n", colour, drawn, without_paths);
    EXPECT_GE(drawn, kMinPixels) << colour << " missing from the rendered page";
    EXPECT_LT(without_paths, kMinPixels) << colour << " found without the plot paths";
  }
  // RPE boxes (filled rectangles, not paths).
  EXPECT_GE(CountColour(good, "#9ecae1", 4), 1000);
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace mcvo
