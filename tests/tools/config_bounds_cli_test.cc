// `mcvo run` with config values that validation used to accept and that then
// exhausted memory or ran for minutes (issue 57, item 8): each now stops at
// start-up with exit 3 and one error line naming the config file and the key
// (docs/config.md), and leaves no output folder behind.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tools/fixture_cache.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::ErrorLines;
using mcvo::test::Quote;
using mcvo::test::Result;
using mcvo::test::RunMcvoWithin;
using mcvo::test::SmallMonoRender;

fs::path Root() {
  static const fs::path dir = mcvo::test::ProcessScratch("mcvo_config_bounds_cli_test");
  return dir;
}

struct Case {
  std::string name;
  std::string json;
  std::string pointer;
  std::string what;  // also in the error line
};

// Runs `mcvo run` on the tiny render with the case's config and checks the
// contract: exit 3 within 60 s, one error line naming the file, the key and
// what is wrong, no output folder.
void ExpectCleanFailure(const Case& c) {
  SCOPED_TRACE(c.name);
  const fs::path dir = Root() / c.name;
  fs::create_directories(dir);
  const fs::path config = dir / "cfg.json";
  std::ofstream(config) << c.json;
  const fs::path out = dir / "out";
  const Result r = RunMcvoWithin(60, "run --dataset " + Quote(SmallMonoRender().string()) + " --config " +
                                         Quote(config.string()) + " --out " + Quote(out.string()));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  const std::vector<std::string> lines = ErrorLines(r.output);
  ASSERT_EQ(lines.size(), 1u) << r.output;
  EXPECT_NE(lines[0].find(config.string() + ": " + c.pointer + ": "), std::string::npos) << lines[0];
  EXPECT_NE(lines[0].find(c.what), std::string::npos) << lines[0];
  EXPECT_EQ(lines[0].find("internal error"), std::string::npos) << lines[0];
  EXPECT_FALSE(fs::exists(out)) << "output folder left behind";
  for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
    EXPECT_EQ(entry.path().filename().string().find("out.tmp"), std::string::npos) << entry.path();
  }
}

TEST(ConfigBoundsCli, TheIssuesValuesFailAtStartUpNamingTheKey) {
  const std::vector<Case> cases = {
      {"lk_window_100001", R"({"frontend": {"lk": {"window_px": 100001}}})", "/frontend/lk/window_px",
       "100001 is above the maximum 255"},
      {"lk_window_1001", R"({"frontend": {"lk": {"window_px": 1001}}})", "/frontend/lk/window_px",
       "1001 is above the maximum 255"},
      {"clahe_tile_grid", R"({"frontend": {"clahe": {"tile_grid": 100000}}})", "/frontend/clahe/tile_grid",
       "100000 is above the maximum 256"},
      {"anchor_half_size", R"({"frontend": {"anchor": {"half_size_px": 100000}}})",
       "/frontend/anchor/half_size_px", "100000 is above the maximum 127"},
      {"backend_window", R"({"backend": {"window_size": 2000000000}})", "/backend/window_size",
       "2000000000 is above the maximum 200"},
      {"loop_features", R"({"loop": {"features_per_camera": 1000000000}})", "/loop/features_per_camera",
       "1000000000 is above the maximum 20000"},
  };
  for (const Case& c : cases) ExpectCleanFailure(c);
}

// Within the static bound but larger than the images: checked against the
// rig before any image is decoded. The 352 x 94 camera is a small one: the
// 255 px window is scaled to 185 px on it, still not below its 94 px side.
TEST(ConfigBoundsCli, AWindowLargerThanTheImageFailsNamingTheCamera) {
  ExpectCleanFailure({"lk_window_over_image", R"({"frontend": {"lk": {"window_px": 255}}})",
                      "/frontend/lk/window_px", "camera image_00 (352 x 94 px)"});
}

}  // namespace
