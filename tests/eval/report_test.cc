#include <algorithm>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "eval/trajectory_fixtures.h"
#include "mcvo/eval/report.h"

namespace mcvo {
namespace {

using testing::Helix;
using testing::Transformed;

std::vector<std::string> Keys(const nlohmann::json& object) {
  std::vector<std::string> keys;
  for (const auto& item : object.items()) keys.push_back(item.key());
  std::sort(keys.begin(), keys.end());
  return keys;
}

std::vector<std::string> Sorted(std::vector<std::string> keys) {
  std::sort(keys.begin(), keys.end());
  return keys;
}

EvalResult ExampleResult() {
  const Trajectory gt = Helix(60);
  Trajectory est =
      Transformed(gt, Rigid3d(So3Exp(Eigen::Vector3d(0.0, 0.0, 0.3)), Eigen::Vector3d(1, 2, 3)), 1.1);
  for (size_t k = 0; k < est.poses.size(); ++k)
    est.poses[k].world_from_body.translation.x() += 0.01 * (k % 7);
  EvalOptions options;
  options.align = AlignmentMode::kSim3;
  return EvaluateTrajectory(gt, est, options, "gt.tum", "est.tum");
}

// The keys documented in docs/eval.md; a change here is a change there.
TEST(Report, JsonHasTheDocumentedKeys) {
  const nlohmann::json j = nlohmann::json::parse(EvalResultToJson(ExampleResult()));
  EXPECT_EQ(Keys(j), Sorted({"format", "format_version", "gt", "est", "options", "association", "alignment",
                             "ate", "rpe", "scale", "start_end", "notes"}));
  EXPECT_EQ(j["format"], "mcvo-eval");
  EXPECT_EQ(j["format_version"], kEvalJsonVersion);
  EXPECT_EQ(Keys(j["gt"]), Sorted({"name", "poses"}));
  EXPECT_EQ(j["est"]["name"], "est.tum");
  EXPECT_EQ(Keys(j["options"]), Sorted({"associate", "max_dt_s", "align", "align_num_poses", "rpe_lengths_m",
                                        "rpe_length_percents", "rpe_length_tolerance", "local_scale_window",
                                        "local_scale_min_distance_m"}));
  EXPECT_EQ(Keys(j["association"]),
            Sorted({"mode", "matched", "gt_unmatched", "est_unmatched", "max_abs_dt_s"}));
  EXPECT_EQ(j["association"]["matched"], 60);
  EXPECT_EQ(Keys(j["alignment"]),
            Sorted({"mode", "num_poses", "scale", "quaternion_wxyz", "translation", "collinear"}));
  EXPECT_EQ(j["alignment"]["mode"], "sim3");
  const std::vector<std::string> stats = Sorted({"count", "rmse", "mean", "median", "std", "min", "max"});
  EXPECT_EQ(Keys(j["ate"]), Sorted({"translation_m", "rotation_deg"}));
  EXPECT_EQ(Keys(j["ate"]["translation_m"]), stats);
  EXPECT_EQ(Keys(j["rpe"]), Sorted({"computed", "skipped_reason", "gt_path_length_m", "step", "lengths", "average"}));
  EXPECT_EQ(Keys(j["rpe"]["step"]), Sorted({"count", "translation_m", "rotation_deg"}));
  EXPECT_EQ(Keys(j["rpe"]["step"]["translation_m"]), stats);
  ASSERT_EQ(j["rpe"]["lengths"].size(), 5u);
  EXPECT_EQ(Keys(j["rpe"]["lengths"][0]),
            Sorted({"length_m", "length_percent", "count", "translation_m", "translation_percent",
                    "rotation_deg", "rotation_deg_per_m"}));
  EXPECT_EQ(Keys(j["rpe"]["lengths"][0]["rotation_deg_per_m"]), stats);
  EXPECT_EQ(Keys(j["rpe"]["average"]), Sorted({"num_lengths", "translation_m", "translation_percent",
                                               "rotation_deg", "rotation_deg_per_m"}));
  EXPECT_EQ(Keys(j["scale"]),
            Sorted({"available", "unavailable_reason", "num_poses", "sim3_scale", "est_scale_factor",
                    "scale_error_percent", "scale_error_signed_percent", "drift", "local"}));
  ASSERT_EQ(j["scale"]["drift"].size(), 5u);
  EXPECT_EQ(Keys(j["scale"]["drift"][0]),
            Sorted({"length_m", "length_percent", "count", "ratio", "ratio_sim3_normalized"}));
  EXPECT_EQ(Keys(j["scale"]["local"]), Sorted({"window_poses", "windows", "windows_skipped", "ratio",
                                               "worst_deviation_percent", "median_deviation_percent"}));
  EXPECT_EQ(Keys(j["scale"]["local"]["ratio"]), stats);
  EXPECT_EQ(j["scale"]["local"]["window_poses"], 50);
  EXPECT_EQ(j["scale"]["local"]["windows"], 1);
  EXPECT_EQ(Keys(j["start_end"]), Sorted({"est_distance_m", "est_path_length_m", "est_percent",
                                          "gt_distance_m", "gt_path_length_m", "gt_percent"}));
  EXPECT_TRUE(j["notes"].is_array());
  // est is 1.1 x too large (plus a small wobble): the scale error is near 10 %.
  EXPECT_NEAR(j["scale"]["scale_error_percent"].get<double>(), 10.0, 0.5);
}

TEST(Report, MissingValuesAreNull) {
  const Trajectory gt = Helix(10);
  EvalOptions options;
  options.align = AlignmentMode::kNone;
  options.rpe_lengths_m = {1000.0};  // longer than the path: no segment
  const nlohmann::json j = nlohmann::json::parse(EvalResultToJson(EvaluateTrajectory(gt, gt, options)));
  EXPECT_EQ(j["rpe"]["lengths"][0]["count"], 0);
  EXPECT_TRUE(j["rpe"]["lengths"][0]["translation_m"]["rmse"].is_null());
  EXPECT_TRUE(j["rpe"]["average"]["translation_percent"].is_null());
  EXPECT_TRUE(j["options"]["rpe_length_percents"].is_null());
  EXPECT_EQ(j["options"]["rpe_lengths_m"][0], 1000.0);
}

TEST(Report, OutputsAreDeterministic) {
  const EvalResult a = ExampleResult();
  const EvalResult b = ExampleResult();
  EXPECT_EQ(EvalResultToJson(a), EvalResultToJson(b));
  EXPECT_EQ(EvalResultToMarkdown(a), EvalResultToMarkdown(b));
  EXPECT_EQ(AteErrorsCsv(a), AteErrorsCsv(b));
}

TEST(Report, CsvAndMarkdownContent) {
  const EvalResult result = ExampleResult();
  const std::string csv = AteErrorsCsv(result);
  EXPECT_EQ(csv.rfind("est_index,gt_index,t_s,frame_index,translation_error_m,rotation_error_deg\n", 0), 0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 61);
  // First data line: est 0, gt 0, t = 1 s, no frame index.
  EXPECT_NE(csv.find("\n0,0,1.000000000,,"), std::string::npos) << csv.substr(0, 200);
  const std::string md = EvalResultToMarkdown(result);
  EXPECT_NE(md.find("| translation (m) |"), std::string::npos);
  EXPECT_NE(md.find("| RPE length (m) |"), std::string::npos);
  EXPECT_NE(md.find("scale: sim3"), std::string::npos);
}

TEST(Report, MarkdownEscapesUserTextForHtmlRenderers) {
  // eval.md is Markdown that viewers render with inline HTML: file names and
  // reasons that quote them must not become markup.
  EvalResult result = ExampleResult();
  result.est_name = "<img src=x onerror=alert(1)>.tum";
  result.gt_name = "a|b`c`&d.tum";
  result.rpe.computed = false;
  result.rpe.skipped_reason = "too short: <script>x</script>";
  result.scale.available = false;
  result.scale.unavailable_reason = "no <b>scale</b>";
  result.notes = {"<iframe>\nsecond line", "est_vo.tum"};
  const std::string md = EvalResultToMarkdown(result);
  for (const char* raw : {"<img", "<script>", "<b>", "<iframe>", "|b`c`&d"})
    EXPECT_EQ(md.find(raw), std::string::npos) << raw << " in\n" << md;
  EXPECT_NE(md.find("## mcvo eval: &lt;img src=x onerror=alert(1)&gt;.tum vs a\\|b\\`c\\`&amp;d.tum\n"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("RPE skipped: too short: &lt;script&gt;x&lt;/script&gt;\n"), std::string::npos) << md;
  EXPECT_NE(md.find("scale: not available (no &lt;b&gt;scale&lt;/b&gt;)\n"), std::string::npos) << md;
  EXPECT_NE(md.find("- &lt;iframe&gt; second line\n"), std::string::npos) << md;
  EXPECT_NE(md.find("- est_vo.tum\n"), std::string::npos) << md;  // emphasis characters stay
}

}  // namespace
}  // namespace mcvo
