// The bad-input catalogue: what a user's broken file does to `mcvo info`,
// `run`, `eval`, `config`, `batch` and `regress`. Each case starts from a
// valid dataset (a small one-camera render), breaks one thing, and runs one
// command. The contract (docs/cli.md, "Errors"): exit 2 (usage) or 3 (input),
// one error line that names the file and where in it (line or JSON pointer),
// no output folder left behind, no crash, no hang (60 s limit). A few inputs
// that look odd but are valid (paths with spaces and non-ASCII letters, a
// JPEG named .png) must simply work. Batch isolates a run whose dataset is
// missing instead (docs/batch-and-regress.md): its own case below.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "mcvo/util/file.h"
#include "tools/fixture_cache.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::ErrorLines;
using mcvo::test::Quote;
using mcvo::test::Result;
using mcvo::test::RunMcvoWithin;
using mcvo::test::SmallMonoRender;

constexpr int kLimitSeconds = 60;

fs::path Root() {
  static const fs::path dir = mcvo::test::ProcessScratch("mcvo_bad_input_test");
  return dir;
}

std::string Read(const fs::path& path) { return mcvo::ReadFileToString(path); }
void Write(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}
// Replaces the first match of `pattern` in the file (the case fails when there is none).
void Edit(const fs::path& path, const std::string& pattern, const std::string& replacement) {
  const std::string text = Read(path);
  const std::string edited =
      std::regex_replace(text, std::regex(pattern), replacement, std::regex_constants::format_first_only);
  ASSERT_NE(edited, text) << "pattern " << pattern << " not in " << path;
  Write(path, edited);
}

// A fresh copy of the base dataset for one case.
fs::path CopyOfBase(const std::string& name) {
  const fs::path dir = Root() / "cases" / name;
  fs::remove_all(dir);
  fs::create_directories(dir.parent_path());
  fs::copy(SmallMonoRender(), dir, fs::copy_options::recursive);
  return dir;
}

struct Case {
  std::string name;
  // Breaks the copy of the dataset `d` (and may write other files under `w`);
  // returns the mcvo arguments (quoted), which write any output into `out`.
  std::function<std::string(const fs::path& d, const fs::path& w, const fs::path& out)> setup;
  int exit_code;                      // 2 or 3
  std::vector<std::string> expected;  // each in the error line ("{d}", "{w}" replaced)
};

std::string RunArgs(const fs::path& d, const fs::path& out, const std::string& extra = "") {
  return "run --dataset " + Quote(d.string()) + " --out " + Quote(out.string()) + extra;
}
fs::path Image(const fs::path& d, int frame) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.png", frame);
  return d / "images" / "image_00" / name;
}
std::string Config(const fs::path& w, const std::string& json) {
  Write(w / "config.json", json);
  return " --config " + Quote((w / "config.json").string());
}

// Appends a copy of the rig's first camera, named `name`, to its camera list.
void AppendCopyOfFirstCamera(const fs::path& rig_json, const std::string& name) {
  const std::string rig = Read(rig_json);
  const size_t first = rig.find('{', rig.find('['));
  const size_t list_end = rig.rfind(']');
  const size_t last_camera_end = rig.rfind('}', list_end);
  std::string camera = rig.substr(first, last_camera_end - first + 1);
  camera = std::regex_replace(camera, std::regex("\"name\": \"[^\"]*\""), "\"name\": \"" + name + "\"");
  Write(rig_json, rig.substr(0, last_camera_end + 1) + ", " + camera + rig.substr(list_end - 1));
}

std::vector<Case> Catalogue() {
  std::vector<Case> c;
  // rig.json
  c.push_back({"rig_empty",
               [](auto d, auto, auto out) {
                 Write(d / "rig.json", "");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/rig.json", "line 1"}});
  c.push_back({"rig_truncated",
               [](auto d, auto, auto out) {
                 Write(d / "rig.json", Read(d / "rig.json").substr(0, 100));
                 return RunArgs(d, out);
               },
               3,
               {"{d}/rig.json", "line 7"}});
  c.push_back({"rig_infinite",
               [](auto d, auto, auto out) {
                 Edit(d / "rig.json", "\"params\": \\[[0-9.]+", "\"params\": [1e999");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/rig.json", "/cameras/0/params/0", "out of range"}});
  c.push_back({"rig_not_orthonormal",
               [](auto d, auto, auto out) {
                 Edit(d / "rig.json", "\"quaternion_wxyz\": \\[[^\\]]*\\]",
                      "\"rotation\": [[1, 0, 0], [0, 1, 0.1], [0, 0, 1]]");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/rig.json", "/cameras/0/cam_from_rig/rotation", "not orthonormal"}});
  c.push_back({"rig_negative_focal",
               [](auto d, auto, auto out) {
                 Edit(d / "rig.json", "\"params\": \\[", "\"params\": [-");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/rig.json", "/cameras/0/params", "must be > 0"}});
  c.push_back({"rig_zero_width",
               [](auto d, auto, auto out) {
                 Edit(d / "rig.json", "\"width\": [0-9]+", "\"width\": 0");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/rig.json", "/cameras/0/width", ">= 1"}});
  c.push_back({"rig_absurd_size",
               [](auto d, auto, auto out) {
                 Edit(d / "rig.json", "\"height\": [0-9]+", "\"height\": 2000000000");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/rig.json", "/cameras/0/height", "<="}});
  c.push_back({"rig_unknown_model",
               [](auto d, auto, auto out) {
                 Edit(d / "rig.json", "\"pinhole\"", "\"fisheye624\"");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/rig.json", "/cameras/0/model", "fisheye624"}});
  c.push_back({"rig_duplicate_names",
               [](auto d, auto, auto out) {
                 AppendCopyOfFirstCamera(d / "rig.json", "image_00");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/rig.json", "/cameras/1/name", "duplicate camera name"}});
  c.push_back({"rig_camera_count_not_frames",
               [](auto d, auto, auto out) {
                 AppendCopyOfFirstCamera(d / "rig.json", "image_01");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/frames.csv:1", "image_01"}});
  // frames.csv
  c.push_back({"frames_out_of_order",
               [](auto d, auto, auto out) {
                 Edit(d / "frames.csv", "\n1200000000,", "\n1050000000,");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/frames.csv:4", "does not increase"}});
  c.push_back({"frames_duplicate_time",
               [](auto d, auto, auto out) {
                 Edit(d / "frames.csv", "\n1100000000,", "\n1000000000,");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/frames.csv:3", "does not increase"}});
  c.push_back({"frames_header_only",
               [](auto d, auto, auto out) {
                 Write(d / "frames.csv", "t_ns,image_00\n");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/frames.csv", "no frame"}});
  c.push_back({"frames_empty",
               [](auto d, auto, auto out) {
                 Write(d / "frames.csv", "");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/frames.csv", "header"}});
  c.push_back({"image_missing",
               [](auto d, auto, auto out) {
                 fs::remove(Image(d, 5));
                 return RunArgs(d, out);
               },
               3,
               {"{d}/images/image_00/000005.png", "missing", "frames.csv, frame 5"}});
  c.push_back({"image_is_a_folder",
               [](auto d, auto, auto out) {
                 fs::remove(Image(d, 5));
                 fs::create_directory(Image(d, 5));
                 return RunArgs(d, out);
               },
               3,
               {"{d}/images/image_00/000005.png", "is a folder", "frames.csv, frame 5"}});
  c.push_back({"image_symlink_loop",
               [](auto d, auto, auto out) {
                 fs::remove(Image(d, 5));
                 fs::create_symlink("000005.png", Image(d, 5));
                 return RunArgs(d, out);
               },
               3,
               {"{d}/images/image_00/000005.png", "symbolic link loop"}});
  c.push_back({"image_wrong_size",
               [](auto d, auto, auto out) {
                 cv::imwrite(Image(d, 5).string(), cv::Mat(50, 60, CV_8UC1, cv::Scalar(128)));
                 return RunArgs(d, out);
               },
               3,
               {"{d}/images/image_00/000005.png", "60 x 50", "expects"}});
  c.push_back({"image_truncated_png",
               [](auto d, auto, auto out) {
                 Write(Image(d, 5), Read(Image(d, 5)).substr(0, 300));
                 return RunArgs(d, out);
               },
               3,
               {"{d}/images/image_00/000005.png", "cannot decode image"}});
  c.push_back({"image_zero_bytes",
               [](auto d, auto, auto out) {
                 Write(Image(d, 5), "");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/images/image_00/000005.png", "empty image file"}});
  // groundtruth.tum
  c.push_back({"gt_nan",
               [](auto d, auto, auto out) {
                 Edit(d / "groundtruth.tum", "\n(1\\.100000000) [^ ]+ ", "\n$1 nan ");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/groundtruth.tum:3", "finite number"}});
  c.push_back({"gt_short_row",
               [](auto d, auto, auto out) {
                 Edit(d / "groundtruth.tum", " [^ \n]+\n(1\\.2)", "\n$1");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/groundtruth.tum:3", "expected 8 fields"}});
  c.push_back({"gt_quaternion_not_unit",
               [](auto d, auto, auto out) {
                 Edit(d / "groundtruth.tum", "\n(1\\.300000000( [^ ]+){3}) [^ ]+ ", "\n$1 0.5 ");
                 return RunArgs(d, out);
               },
               3,
               {"{d}/groundtruth.tum:5", "not unit"}});
  // config
  c.push_back({"config_unknown_key",
               [](auto d, auto w, auto out) {
                 return RunArgs(d, out, Config(w, R"({"backend": {"window_sise": 10}})"));
               },
               3,
               {"{w}/config.json", "/backend/window_sise", "unknown key"}});
  c.push_back({"config_wrong_type",
               [](auto d, auto w, auto out) {
                 return RunArgs(d, out, Config(w, R"({"backend": {"window_size": "ten"}})"));
               },
               3,
               {"{w}/config.json", "/backend/window_size", "expected an integer"}});
  c.push_back({"config_window_size_0",
               [](auto d, auto w, auto out) {
                 return RunArgs(d, out, Config(w, R"({"backend": {"window_size": 0}})"));
               },
               3,
               {"{w}/config.json", "/backend/window_size", ">= 2"}});
  c.push_back({"config_window_size_1",
               [](auto d, auto w, auto out) {
                 return RunArgs(d, out, Config(w, R"({"initializer": {"window_size": 1}})"));
               },
               3,
               {"{w}/config.json", "/initializer/window_size", ">= 2"}});
  c.push_back({"config_zero_features",
               [](auto d, auto w, auto out) {
                 return RunArgs(d, out, Config(w, R"({"frontend": {"max_features_pinhole": 0}})"));
               },
               3,
               {"{w}/config.json", "/frontend/max_features_pinhole"}});
  c.push_back({"config_command_broken_json",
               [](auto, auto w, auto) {
                 Write(w / "broken.json", "{\"backend\": {\n  \"window_size\": 10,\n}");
                 return "config --config " + Quote((w / "broken.json").string());
               },
               3,
               {"{w}/broken.json", "line 3"}});
  // output folder
  c.push_back({"out_under_a_file",
               [](auto d, auto w, auto) {
                 Write(w / "notes.txt", "a file\n");
                 return RunArgs(d, w / "notes.txt" / "out");
               },
               3,
               {"{w}/notes.txt/out", "cannot create the output folder"}});
  c.push_back({"out_is_a_file",
               [](auto d, auto w, auto) {
                 Write(w / "notes.txt", "a file\n");
                 return RunArgs(d, w / "notes.txt");
               },
               3,
               {"{w}/notes.txt", "not a folder"}});
  // --out over or inside the dataset (util/output_folder.h): refused, the dataset untouched.
  c.push_back({"out_inside_the_dataset",
               [](auto d, auto, auto) { return RunArgs(d, d / "frames.csv"); },
               3,
               {"{d}/frames.csv", "inside the input folder {d}"}});
  c.push_back({"out_is_the_dataset",
               [](auto d, auto, auto) { return RunArgs(d, d, " --force"); },
               3,
               {"is the input {d}"}});
  c.push_back({"out_not_creatable",
               [](auto d, auto, auto) { return RunArgs(d, "/proc/mcvo_out"); },
               3,
               {"/proc/mcvo_out", "cannot create the output folder"}});
  // command line
  c.push_back({"threads_negative",
               [](auto d, auto, auto out) { return RunArgs(d, out, " --threads -5"); },
               2,
               {"--threads", ">= 0"}});
  c.push_back({"frames_negative",
               [](auto d, auto, auto out) { return RunArgs(d, out, " --frames -1"); },
               2,
               {"--frames", ">= 0"}});
  c.push_back({"dataset_symlink_loop",
               [](auto, auto w, auto out) {
                 fs::create_symlink(w / "loop_b", w / "loop_a");
                 fs::create_symlink(w / "loop_a", w / "loop_b");
                 return RunArgs(w / "loop_a", out);
               },
               3,
               {"{w}/loop_a", "symbolic link loop"}});
  // eval, regress, batch
  c.push_back({"eval_empty_estimate",
               [](auto d, auto w, auto out) {
                 Write(w / "empty.tum", "");
                 return "eval --gt " + Quote((d / "groundtruth.tum").string()) + " --est " +
                        Quote((w / "empty.tum").string()) + " --out " + Quote(out.string());
               },
               3,
               {"{w}/empty.tum", "no data lines"}});
  c.push_back({"eval_no_time_overlap",
               [](auto d, auto w, auto out) {
                 std::string shifted = Read(d / "groundtruth.tum");
                 shifted = std::regex_replace(shifted, std::regex("\n([0-9])\\."), "\n900$1.");  // +9000 s
                 Write(w / "late.tum", shifted);
                 return "eval --gt " + Quote((d / "groundtruth.tum").string()) + " --est " +
                        Quote((w / "late.tum").string()) + " --out " + Quote(out.string());
               },
               3,
               {"{w}/late.tum", "no pose matches"}});
  c.push_back({"regress_against_an_empty_folder",
               [](auto, auto w, auto) {
                 fs::create_directories(w / "empty_a");
                 fs::create_directories(w / "empty_b");
                 return "regress --baseline " + Quote((w / "empty_a").string()) + " --candidate " +
                        Quote((w / "empty_b").string());
               },
               3,
               {"{w}/empty_a", "no run.json"}});
  c.push_back({"batch_manifest_broken",
               [](auto, auto w, auto out) {
                 Write(w / "manifest.json", "{\"runs\": [\n  {\"name\": \"a\"\n");
                 return "batch --manifest " + Quote((w / "manifest.json").string()) + " --out " +
                        Quote(out.string());
               },
               3,
               {"{w}/manifest.json", "line 3"}});
  return c;
}

std::string Substitute(std::string text, const fs::path& d, const fs::path& w) {
  for (const auto& [key, value] :
       {std::pair<std::string, std::string>{"{d}", d.string()}, {"{w}", w.string()}}) {
    for (size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + value.size())) {
      text.replace(at, key.size(), value);
    }
  }
  return text;
}

TEST(BadInputCatalogue, EveryCaseFailsCleanlyNamingTheFileAndPlace) {
  const std::vector<Case> cases = Catalogue();
  EXPECT_GE(cases.size(), 30u);
  for (const Case& bad : cases) {
    SCOPED_TRACE(bad.name);
    const fs::path d = CopyOfBase(bad.name);
    const fs::path w = Root() / "work" / bad.name;
    fs::remove_all(w);
    fs::create_directories(w);
    const fs::path out = w / "out";
    const std::string args = bad.setup(d, w, out);
    if (::testing::Test::HasFatalFailure()) continue;
    const Result r = RunMcvoWithin(kLimitSeconds, args);
    EXPECT_EQ(r.exit_code, bad.exit_code) << "mcvo " << args << "\n" << r.output;
    const std::vector<std::string> errors = ErrorLines(r.output);
    ASSERT_EQ(errors.size(), 1u) << r.output;
    for (const std::string& expected : bad.expected) {
      EXPECT_NE(errors.front().find(Substitute(expected, d, w)), std::string::npos)
          << "expected '" << Substitute(expected, d, w) << "' in: " << errors.front();
    }
    EXPECT_FALSE(fs::exists(out)) << "output left behind for " << bad.name;
    // Nothing staged next to it either.
    for (const fs::directory_entry& entry : fs::directory_iterator(w)) {
      EXPECT_EQ(entry.path().filename().string().find("out.tmp"), std::string::npos) << entry.path();
    }
  }
}

// Odd but valid: a dataset and an output folder whose paths hold spaces and
// non-ASCII letters, and an image that is a JPEG named .png (decoded by its
// content, as OpenCV does). Both run to the end and write their outputs.
TEST(BadInputCatalogue, OddButValidInputsWork) {
  const fs::path d = Root() / "odd paths" / "séquence ü 1";
  fs::create_directories(d.parent_path());
  fs::remove_all(d);
  fs::copy(SmallMonoRender(), d, fs::copy_options::recursive);
  const cv::Mat image = cv::imread(Image(d, 5).string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(image.empty());
  std::vector<uchar> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", image, jpeg));
  Write(Image(d, 5), std::string(jpeg.begin(), jpeg.end()));
  const fs::path out = Root() / "odd paths" / "résultat 1";
  Result r = RunMcvoWithin(kLimitSeconds, "info --dataset " + Quote(d.string()));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  r = RunMcvoWithin(kLimitSeconds, RunArgs(d, out));
  // 12 frames of one camera may or may not initialise: 0 (posed) or 5 (none
  // posed, said); either way the run finished and wrote everything.
  EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 5) << r.output;
  EXPECT_TRUE(ErrorLines(r.output).empty()) << r.output;
  EXPECT_TRUE(fs::is_regular_file(out / "run.json")) << r.output;
  EXPECT_TRUE(fs::is_regular_file(out / "frame_stats.csv")) << r.output;
}

// Batch isolates a run whose dataset is not there (a missing mount must not
// stop the other runs of a night's batch): that run fails with the path
// named in the summary, the others run, the exit code is 4
// (docs/batch-and-regress.md), and no folder is made for the failed run.
TEST(BadInputCatalogue, BatchIsolatesARunWhoseDatasetIsMissing) {
  const fs::path w = Root() / "batch_missing";
  fs::remove_all(w);
  fs::create_directories(w);
  Write(w / "manifest.json",
        "{\"runs\": [\n  {\"name\": \"gone\", \"dataset\": {\"root\": \"not_there\"}},\n"
        "  {\"name\": \"here\", \"dataset\": {\"root\": " +
            nlohmann::json(SmallMonoRender().string()).dump() + "}, \"max_frames\": 3}\n]}");
  const Result r = RunMcvoWithin(kLimitSeconds, "batch --manifest " + Quote((w / "manifest.json").string()) +
                                                    " --out " + Quote((w / "out").string()));
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find((w / "not_there").string()), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(w / "out" / "gone"));
  EXPECT_TRUE(fs::is_regular_file(w / "out" / "here" / "run.json")) << r.output;
}

}  // namespace
