// mcvo regress (pipeline/regress.h) on small hand-made run folders:
// identical folders, differences only in ignored keys, trajectories compared
// pose by pose, CSV cells and JSON values within tolerances (and per-value
// overrides), rounded numbers in text, missing files, bad tolerance files.
#include "mcvo/pipeline/regress.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <map>
#include <string>
#include <system_error>

#include <nlohmann/json.hpp>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/sha256.h"
#include "test_temp_dir.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

fs::path Root() { return mcvo::testing::TestTempDir("regress_test"); }

using Files = std::map<std::string, std::string>;

Files BaseFiles() {
  return {
      {"trajectory.tum",
       "1.000000000 0 0 0 0 0 0 1\n"
       "1.100000000 1 0.5 0 0 0 0.0499791692706783 0.998750260394966\n"
       "1.200000000 2 1 0.1 0 0 0.0998334166468282 0.995004165278026\n"
       "1.300000000 3 1.5 0.2 0.01 0 0.149438132473599 0.988771077936042\n"},
      {"trajectory_kitti.txt", "0 1 0 0 0 0 1 0 0 0 0 1 0\n1 1 0 0 1 0 1 0 0.5 0 0 1 0\n"},
      {"frame_stats.csv",
       "frame,t_ns,landmarks,ba_final_cost,note\n0,1000,10,0.5,\"a, b\"\n1,1100,12,0.25,\"\"\n"},
      {"eval/eval.json",
       R"({"gt": {"name": "/data/seq/groundtruth"}, "ate": {"rmse": 0.125, "count": 4}, "notes": ["x"]})"},
      {"eval/eval.md", "## mcvo eval\n| ATE | 0.1250 | 4 |\nscale error 0.500 %\n"},
      {"timing.csv", "frame,seconds\n0,0.1\n"},
  };
}

// Writes a run folder: the files and a run.json that lists them.
fs::path MakeRun(const std::string& name, const Files& files, const std::string& version = "1.0",
                 double seconds = 1.0, const Files& listed_only = {}) {
  const fs::path dir = Root() / name;
  fs::remove_all(dir);
  nlohmann::ordered_json run;
  run["program"] = "mcvo";
  run["version"] = version;
  run["command_line"] = "run --out " + dir.string();
  run["config"] = {{"backend", {{"window_size", 10}}}};
  run["dataset"] = {{"root", dir.string() + "/seq"}, {"frames", 4}};
  nlohmann::ordered_json outputs = nlohmann::ordered_json::object();
  for (const auto& [file, text] : files) {
    fs::create_directories((dir / file).parent_path());
    WriteFileAtomic(dir / file, text);
    outputs[file] = Sha256Hex(text);
  }
  for (const auto& [file, text] : listed_only) outputs[file] = Sha256Hex(text);
  run["outputs_sha256"] = outputs;
  run["result"] = {{"frames", 4}, {"ate_rmse_m", 0.125}};
  run["timing"] = {{"seconds_total", seconds}};
  WriteFileAtomic(dir / "run.json", run.dump(2));
  return dir;
}

const FileComparison& Find(const RegressReport& report, const std::string& file) {
  for (const FileComparison& f : report.files) {
    if (f.file == file) return f;
  }
  static FileComparison none;
  ADD_FAILURE() << file << " not compared";
  return none;
}

RegressOptions Tolerant(double translation_m = 0.001, double rotation_deg = 0.01, double relative = 1e-6) {
  RegressOptions options;
  options.use_tolerances = true;
  options.translation_m = translation_m;
  options.rotation_deg = rotation_deg;
  options.numbers.relative = relative;
  return options;
}

TEST(Regress, IdenticalFoldersAreEqual) {
  const fs::path a = MakeRun("same_a", BaseFiles()), b = MakeRun("same_b", BaseFiles());
  const RegressReport report = CompareRunFolders(a, b, RegressOptions());
  EXPECT_TRUE(report.Equal());
  // run.json first, then the listed files, without timing.csv.
  ASSERT_EQ(report.files.size(), 6u);
  EXPECT_EQ(report.files[0].file, "run.json");
  for (const FileComparison& f : report.files) {
    EXPECT_NE(f.file, "timing.csv");
    if (f.file != "run.json" && f.file != "eval/eval.json") {
      EXPECT_EQ(f.verdict, FileVerdict::kIdentical) << f.file;
    }
  }
  // run.json differs in the command line and dataset root (paths), eval.json in the gt name.
  EXPECT_EQ(Find(report, "run.json").verdict, FileVerdict::kEquivalent);
  EXPECT_EQ(Find(report, "eval/eval.json").verdict, FileVerdict::kIdentical);
  const std::string text = FormatRegressReport(report, RegressOptions());
  EXPECT_NE(text.find("result: equal (6 files"), std::string::npos) << text;
}

TEST(Regress, TimingVersionAndPathsAreIgnored) {
  Files other = BaseFiles();
  other["timing.csv"] = "frame,seconds\n0,0.7\n";
  other["eval/eval.json"] =
      R"({"gt": {"name": "/elsewhere/groundtruth"}, "ate": {"rmse": 0.125, "count": 4}, "notes": ["x"]})";
  const RegressReport report =
      CompareRunFolders(MakeRun("ign_a", BaseFiles()), MakeRun("ign_b", other, "2.0", 5.0), RegressOptions());
  EXPECT_TRUE(report.Equal()) << FormatRegressReport(report, RegressOptions());
  EXPECT_EQ(Find(report, "eval/eval.json").verdict, FileVerdict::kEquivalent);
  EXPECT_EQ(Find(report, "run.json").verdict, FileVerdict::kEquivalent);
}

TEST(Regress, PerturbedTrajectoryFailsWithWhereAndHowMuch) {
  Files moved = BaseFiles();
  // Pose 2 moved by 1 cm along z.
  moved["trajectory.tum"].replace(moved["trajectory.tum"].find("2 1 0.1"), 7, "2 1 0.11");
  const fs::path a = MakeRun("traj_a", BaseFiles()), b = MakeRun("traj_b", moved);

  RegressReport report = CompareRunFolders(a, b, RegressOptions());
  EXPECT_FALSE(report.Equal());
  const FileComparison& exact = Find(report, "trajectory.tum");
  EXPECT_EQ(exact.verdict, FileVerdict::kDifferent);
  EXPECT_NE(exact.detail.find("pose 2 (t 1.200000000 s): 0.01 m"), std::string::npos) << exact.detail;

  report = CompareRunFolders(a, b, Tolerant(0.001));
  const FileComparison& tolerant = Find(report, "trajectory.tum");
  EXPECT_EQ(tolerant.verdict, FileVerdict::kDifferent);
  EXPECT_NE(tolerant.detail.find("pose 2 (t 1.200000000 s): 0.01 m, 0 deg apart (tolerance 0.001 m"),
            std::string::npos)
      << tolerant.detail;
  const std::string text = FormatRegressReport(report, Tolerant(0.001));
  EXPECT_NE(text.find("  trajectory.tum        DIFFERENT: pose 2 (t 1.200000000 s)"), std::string::npos)
      << text;
  EXPECT_NE(text.find("result: DIFFERENT (1 of 6 files)"), std::string::npos) << text;

  // Within a 2 cm tolerance.
  report = CompareRunFolders(a, b, Tolerant(0.02));
  EXPECT_TRUE(report.Equal());
  EXPECT_EQ(Find(report, "trajectory.tum").verdict, FileVerdict::kWithinTolerance);
  EXPECT_NE(Find(report, "trajectory.tum").detail.find("max 0.01 m at pose 2"), std::string::npos)
      << Find(report, "trajectory.tum").detail;

  // A rotation beyond its tolerance (about 1 deg about x on the last pose).
  Files turned = BaseFiles();
  turned["trajectory.tum"].replace(turned["trajectory.tum"].find("0.01 0 0.149"), 12, "0.0187 0 0.149");
  report = CompareRunFolders(a, MakeRun("traj_c", turned), Tolerant(0.02, 0.5));
  EXPECT_EQ(Find(report, "trajectory.tum").verdict, FileVerdict::kDifferent);
  EXPECT_NE(Find(report, "trajectory.tum").detail.find("pose 3"), std::string::npos)
      << Find(report, "trajectory.tum").detail;

  // A missing pose, and poses at other times.
  Files shorter = BaseFiles();
  shorter["trajectory.tum"].erase(shorter["trajectory.tum"].find("1.300000000"));
  report = CompareRunFolders(a, MakeRun("traj_d", shorter), Tolerant(1.0, 10.0));
  EXPECT_NE(Find(report, "trajectory.tum")
                .detail.find("4 poses vs 3; first unmatched: pose 3 (t 1.300000000 s) in baseline"),
            std::string::npos)
      << Find(report, "trajectory.tum").detail;
  Files shifted = BaseFiles();
  shifted["trajectory.tum"].replace(shifted["trajectory.tum"].find("1.100000000"), 11, "1.150000000");
  report = CompareRunFolders(a, MakeRun("traj_e", shifted), Tolerant(1.0, 10.0));
  EXPECT_NE(
      Find(report, "trajectory.tum").detail.find("pose 1 is at t 1.100000000 s in baseline, t 1.150000000 s"),
      std::string::npos)
      << Find(report, "trajectory.tum").detail;
}

TEST(Regress, CsvCellsWithinTheirColumnsTolerance) {
  Files changed = BaseFiles();
  changed["frame_stats.csv"] =
      "frame,t_ns,landmarks,ba_final_cost,note\n0,1000,10,0.5000001,\"a, b\"\n1,1100,12,0.25,\"\"\n";
  const fs::path a = MakeRun("csv_a", BaseFiles()), b = MakeRun("csv_b", changed);
  RegressReport report = CompareRunFolders(a, b, RegressOptions());
  EXPECT_EQ(Find(report, "frame_stats.csv").verdict, FileVerdict::kDifferent);
  EXPECT_NE(Find(report, "frame_stats.csv").detail.find("line 2, column ba_final_cost: 0.5 vs 0.5000001"),
            std::string::npos)
      << Find(report, "frame_stats.csv").detail;
  report = CompareRunFolders(a, b, Tolerant(0.001, 0.01, 1e-6));
  EXPECT_EQ(Find(report, "frame_stats.csv").verdict, FileVerdict::kWithinTolerance);
  EXPECT_TRUE(report.Equal());
  report = CompareRunFolders(a, b, Tolerant(0.001, 0.01, 1e-8));
  EXPECT_EQ(Find(report, "frame_stats.csv").verdict, FileVerdict::kDifferent);
  // An override for that column lets it pass again; one for another column does not.
  RegressOptions options = Tolerant(0.001, 0.01, 1e-8);
  options.overrides.push_back({"frame_stats.csv", "landmarks", {0.0, 1e-3}});
  EXPECT_EQ(Find(CompareRunFolders(a, b, options), "frame_stats.csv").verdict, FileVerdict::kDifferent);
  options.overrides.insert(options.overrides.begin(), {"*.csv", "ba_*_cost", {1e-6, 0.0}});
  EXPECT_EQ(Find(CompareRunFolders(a, b, options), "frame_stats.csv").verdict, FileVerdict::kWithinTolerance);

  // Counts and text are not numbers to round away: 12 -> 13 landmarks, a changed note.
  Files counts = BaseFiles();
  counts["frame_stats.csv"] =
      "frame,t_ns,landmarks,ba_final_cost,note\n0,1000,10,0.5,\"a, b\"\n1,1100,13,0.25,\"c\"\n";
  report = CompareRunFolders(a, MakeRun("csv_c", counts), Tolerant(0.001, 0.01, 1e-3));
  const FileComparison& f = Find(report, "frame_stats.csv");
  EXPECT_EQ(f.verdict, FileVerdict::kDifferent);
  EXPECT_NE(f.detail.find("line 3, column landmarks: 12 vs 13"), std::string::npos) << f.detail;
  EXPECT_NE(f.detail.find("2 cell(s) beyond tolerance"), std::string::npos) << f.detail;
  // A different header.
  Files header = BaseFiles();
  header["frame_stats.csv"] =
      "frame,t_ns,landmark,ba_final_cost,note\n0,1000,10,0.5,\"a, b\"\n1,1100,12,0.25,\"\"\n";
  report = CompareRunFolders(a, MakeRun("csv_d", header), Tolerant());
  EXPECT_NE(Find(report, "frame_stats.csv").detail.find("header differs"), std::string::npos);
}

TEST(Regress, JsonValuesAndRoundedText) {
  Files changed = BaseFiles();
  changed["eval/eval.json"] =
      R"({"gt": {"name": "/x"}, "ate": {"rmse": 0.12501, "count": 4}, "notes": ["x"]})";
  changed["eval/eval.md"] = "## mcvo eval\n| ATE | 0.1251 | 4 |\nscale error 0.500 %\n";
  const fs::path a = MakeRun("json_a", BaseFiles()), b = MakeRun("json_b", changed);
  RegressReport report = CompareRunFolders(a, b, RegressOptions());
  EXPECT_EQ(Find(report, "eval/eval.json").verdict, FileVerdict::kDifferent);
  EXPECT_NE(Find(report, "eval/eval.json").detail.find("/ate/rmse: 0.125 vs 0.12501"), std::string::npos)
      << Find(report, "eval/eval.json").detail;
  EXPECT_EQ(Find(report, "eval/eval.md").verdict, FileVerdict::kDifferent);
  EXPECT_NE(
      Find(report, "eval/eval.md").detail.find("line 2: '| ATE | 0.1250 | 4 |' vs '| ATE | 0.1251 | 4 |'"),
      std::string::npos)
      << Find(report, "eval/eval.md").detail;

  // 1e-4 relative: the JSON number passes, and the Markdown number passes by
  // one unit of its last printed digit.
  report = CompareRunFolders(a, b, Tolerant(0.001, 0.01, 1e-4));
  EXPECT_EQ(Find(report, "eval/eval.json").verdict, FileVerdict::kWithinTolerance);
  EXPECT_EQ(Find(report, "eval/eval.md").verdict, FileVerdict::kWithinTolerance);
  EXPECT_TRUE(report.Equal());
  // A pointer override, and an ignored pointer.
  RegressOptions options = Tolerant(0.001, 0.01, 0.0);
  EXPECT_EQ(Find(CompareRunFolders(a, b, options), "eval/eval.json").verdict, FileVerdict::kDifferent);
  options.overrides.push_back({"eval/*.json", "/ate/*", {1e-4, 0.0}});
  EXPECT_EQ(Find(CompareRunFolders(a, b, options), "eval/eval.json").verdict, FileVerdict::kWithinTolerance);
  options = RegressOptions();
  options.ignore_json = {"eval/eval.json:/ate/rmse"};
  EXPECT_EQ(Find(CompareRunFolders(a, b, options), "eval/eval.json").verdict, FileVerdict::kEquivalent);

  // Two units of the last digit are a difference; so is a changed word or a missing key.
  Files far = BaseFiles();
  far["eval/eval.md"] = "## mcvo eval\n| ATE | 0.1252 | 4 |\nscale error 0.500 %\n";
  far["eval/eval.json"] = R"({"gt": {"name": "/x"}, "ate": {"count": 4}, "notes": ["y"]})";
  report = CompareRunFolders(a, MakeRun("json_c", far), Tolerant(0.001, 0.01, 1e-6));
  EXPECT_EQ(Find(report, "eval/eval.md").verdict, FileVerdict::kDifferent);
  EXPECT_EQ(Find(report, "eval/eval.json").verdict, FileVerdict::kDifferent);
  EXPECT_NE(Find(report, "eval/eval.json").detail.find("/ate/rmse: missing in candidate (and 1 more)"),
            std::string::npos)
      << Find(report, "eval/eval.json").detail;
  // run.json's config and results are compared.
  const fs::path c = MakeRun("json_d", BaseFiles());
  nlohmann::json run = nlohmann::json::parse(ReadFileToString(c / "run.json"));
  run["config"]["backend"]["window_size"] = 11;
  WriteFileAtomic(c / "run.json", run.dump());
  report = CompareRunFolders(a, c, Tolerant(1.0, 1.0, 0.01));
  EXPECT_EQ(Find(report, "run.json").verdict, FileVerdict::kDifferent);
  EXPECT_NE(Find(report, "run.json").detail.find("/config/backend/window_size: 10 vs 11"), std::string::npos);
}

TEST(Regress, NumbersInsideTextAndSvg) {
  Files a_files = BaseFiles(), b_files = BaseFiles();
  a_files["report.html"] = "<p>matched 18 of 18</p>\n<path d=\"M12.5,3.25 L13.75,-4.5e-2\"/>\n";
  b_files["report.html"] = "<p>matched 18 of 18</p>\n<path d=\"M12.5000001,3.25 L13.75,-4.50001e-2\"/>\n";
  const fs::path a = MakeRun("text_a", a_files);
  RegressReport report = CompareRunFolders(a, MakeRun("text_b", b_files), Tolerant(0.001, 0.01, 1e-4));
  EXPECT_EQ(Find(report, "report.html").verdict, FileVerdict::kWithinTolerance)
      << Find(report, "report.html").detail;
  EXPECT_NE(Find(report, "report.html").detail.find("at line 2"), std::string::npos);
  report = CompareRunFolders(a, MakeRun("text_b", b_files), RegressOptions());
  EXPECT_EQ(Find(report, "report.html").verdict, FileVerdict::kDifferent);
  // A count is not rounded: 18 -> 19 is a difference; so is changed text around equal numbers.
  Files c_files = BaseFiles();
  c_files["report.html"] = "<p>matched 19 of 18</p>\n<path d=\"M12.5,3.25 L13.75,-4.5e-2\"/>\n";
  report = CompareRunFolders(a, MakeRun("text_c", c_files), Tolerant(0.001, 0.01, 1e-2));
  EXPECT_EQ(Find(report, "report.html").verdict, FileVerdict::kDifferent);
  EXPECT_NE(Find(report, "report.html")
                .detail.find("line 1: '<p>matched 18 of 18</p>' vs '<p>matched 19 of 18</p>'"),
            std::string::npos)
      << Find(report, "report.html").detail;
  c_files["report.html"] = "<p>matched 18 of 18</p>\n<path d=\"M12.5,3.25 l13.75,-4.5e-2\"/>\n";
  report = CompareRunFolders(a, MakeRun("text_d", c_files), Tolerant(1.0, 1.0, 1.0));
  EXPECT_EQ(Find(report, "report.html").verdict, FileVerdict::kDifferent);
}

TEST(Regress, MissingFilesAreDifferences) {
  Files fewer = BaseFiles();
  fewer.erase("eval/eval.md");
  const fs::path a = MakeRun("miss_a", BaseFiles()), b = MakeRun("miss_b", fewer);
  RegressReport report = CompareRunFolders(a, b, Tolerant(1.0, 10.0, 1.0));
  EXPECT_FALSE(report.Equal());
  EXPECT_EQ(Find(report, "eval/eval.md").verdict, FileVerdict::kMissingInCandidate);
  report = CompareRunFolders(b, a, Tolerant(1.0, 10.0, 1.0));
  EXPECT_EQ(Find(report, "eval/eval.md").verdict, FileVerdict::kMissingInBaseline);
  const std::string text = FormatRegressReport(report, RegressOptions());
  EXPECT_NE(text.find("eval/eval.md          MISSING in baseline"), std::string::npos) << text;
  // Listed in run.json but not in the folder: missing too.
  const fs::path c = MakeRun("miss_c", fewer, "1.0", 1.0, {{"eval/eval.md", "x"}});
  EXPECT_EQ(Find(CompareRunFolders(a, c, RegressOptions()), "eval/eval.md").verdict,
            FileVerdict::kMissingInCandidate);
  // Unless ignored.
  RegressOptions options;
  options.ignore_files = {"eval/*.md"};
  report = CompareRunFolders(a, b, options);
  EXPECT_TRUE(report.Equal());
  for (const FileComparison& f : report.files) EXPECT_NE(f.file, "eval/eval.md");
}

TEST(Regress, BadInputThrows) {
  const fs::path a = MakeRun("bad_a", BaseFiles());
  const fs::path empty = Root() / "empty";
  fs::create_directories(empty);
  EXPECT_THROW(CompareRunFolders(a, empty, RegressOptions()), InputError);
  EXPECT_THROW(CompareRunFolders(Root() / "nothing", a, RegressOptions()), InputError);
  WriteFileAtomic(empty / "run.json", "{\"program\": \"mcvo\"}");
  try {
    CompareRunFolders(a, empty, RegressOptions());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/outputs_sha256"), std::string::npos) << e.what();
  }
}

TEST(Regress, ToleranceFile) {
  RegressOptions options;
  ParseRegressTolerances(R"({
    // comment
    "trajectory": {"translation_m": 0.001, "rotation_deg": 0.01},
    "numbers": {"absolute": 1e-9, "relative": 1e-6},
    "overrides": [{"file": "eval/*", "key": "/ate/*", "absolute": 0.01}, {"key": "ba_*", "relative": 0.1}],
    "ignore_files": ["report.html"],
    "ignore_json": ["/x", "eval/eval.json:/y"]
  })",
                         "t.json", &options);
  EXPECT_TRUE(options.use_tolerances);
  EXPECT_EQ(options.translation_m, 0.001);
  EXPECT_EQ(options.rotation_deg, 0.01);
  EXPECT_EQ(options.numbers.absolute, 1e-9);
  EXPECT_EQ(options.numbers.relative, 1e-6);
  ASSERT_EQ(options.overrides.size(), 2u);
  EXPECT_EQ(options.overrides[0].file, "eval/*");
  EXPECT_EQ(options.overrides[0].key, "/ate/*");
  EXPECT_EQ(options.overrides[0].tolerance.absolute, 0.01);
  EXPECT_EQ(options.overrides[0].tolerance.relative, 0.0);
  EXPECT_EQ(options.overrides[1].file, "*");
  EXPECT_EQ(options.overrides[1].tolerance.relative, 0.1);
  EXPECT_EQ(options.ignore_files, std::vector<std::string>{"report.html"});
  EXPECT_EQ(options.ignore_json, (std::vector<std::string>{"/x", "eval/eval.json:/y"}));

  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"trajectory": {"translation": 1}})", "t.json: /trajectory/translation: unknown key"},
      {R"({"numbers": {"relative": -1}})", "t.json: /numbers/relative: must be >= 0"},
      {R"({"overrides": [{"file": "a"}]})", "t.json: /overrides/0/key: missing required key"},
      {R"({"ignore_json": ["run.json:timing"]})", "t.json: /ignore_json/0: expected \"/pointer\""},
      {R"({"tolerance": 1})", "t.json: /tolerance: unknown key"},
  };
  for (const auto& [text, expected] : bad) {
    RegressOptions o;
    try {
      ParseRegressTolerances(text, "t.json", &o);
      ADD_FAILURE() << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  }
}

TEST(Regress, NumberTolerance) {
  EXPECT_TRUE((NumberTolerance{0.0, 0.0}).Accepts(1.5, 1.5));
  EXPECT_FALSE((NumberTolerance{0.0, 0.0}).Accepts(1.5, 1.5000001));
  EXPECT_TRUE((NumberTolerance{1e-6, 0.0}).Accepts(1.5, 1.5000001));
  EXPECT_TRUE((NumberTolerance{0.0, 1e-6}).Accepts(100.0, 100.0001));
  EXPECT_FALSE((NumberTolerance{0.0, 1e-6}).Accepts(100.0, 100.001));
  EXPECT_TRUE((NumberTolerance{0.0, 0.0}).Accepts(std::nan(""), std::nan("")));
  EXPECT_FALSE((NumberTolerance{1.0, 1.0}).Accepts(std::nan(""), 1.0));
}

}  // namespace
}  // namespace mcvo
