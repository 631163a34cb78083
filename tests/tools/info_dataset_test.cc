// `mcvo info --dataset`: the summary of a synthesized dataset, one-line
// errors for a broken one, and usage errors.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>
#include "tools/run_mcvo.h"

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

namespace {

namespace fs = std::filesystem;

using mcvo::test::Quote;
using mcvo::test::Result;
using mcvo::test::RunMcvo;

// One folder per process (ctest runs tests as parallel processes).
class InfoDataset : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("mcvo_info_dataset_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  // A 4-frame KITTI-360 sequence (tiny images), rendered by `mcvo synth`.
  fs::path Synth() {
    const fs::path out = dir_ / "seq";
    const Result synth = RunMcvo("synth --preset kitti360 --frames 4 --image-scale 0.05 --samples 1 --out " +
                                 Quote(out.string()));
    EXPECT_EQ(synth.exit_code, 0) << synth.output;
    return out;
  }
  fs::path dir_;
};

size_t CountLines(const std::string& text) {
  size_t lines = 0;
  for (char c : text) lines += c == '\n' ? 1 : 0;
  return lines;
}

TEST_F(InfoDataset, SummarisesASynthesizedDataset) {
  const fs::path root = Synth();
  const Result result = RunMcvo("info --dataset " + Quote(root.string()));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  for (const std::string& expected :
       {std::string("dataset: ") + root.string(), std::string("  format     generic"),
        std::string("  name       seq"),
        std::string("  frames     4, 1.000000000 s .. 1.300000000 s (0.300 s)"),
        std::string("  interval   median 0.1000 s (10.00 Hz)"), std::string("  gaps       none"),
        std::string("  missing    none"), std::string("  gt         4 poses"),
        std::string("100.0 % of frames have a pose within 10 ms"), std::string("  masks      image_02 ("),
        std::string("camera 3: image_03"), std::string("view overlap at 10 m"),
        std::string("  image_00 - image_01: ")}) {
    EXPECT_NE(result.output.find(expected), std::string::npos) << expected << "\n" << result.output;
  }
}

TEST_F(InfoDataset, CameraSubsetGapsAndMissingImages) {
  const fs::path root = Synth();
  // Frame 2 loses image_01 and frame 3 moves 0.5 s later: a gap.
  const fs::path frames = root / "frames.csv";
  std::string text;
  {
    FILE* in = std::fopen(frames.c_str(), "rb");
    ASSERT_NE(in, nullptr);
    std::array<char, 4096> buffer{};
    size_t n = 0;
    while ((n = std::fread(buffer.data(), 1, buffer.size(), in)) > 0) text.append(buffer.data(), n);
    std::fclose(in);
  }
  const auto replace = [&](const std::string& from, const std::string& to) {
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  };
  replace(",images/image_01/000002.png", ",");
  replace("1300000000,", "1800000000,");
  {
    FILE* out = std::fopen(frames.c_str(), "wb");
    ASSERT_NE(out, nullptr);
    std::fwrite(text.data(), 1, text.size(), out);
    std::fclose(out);
  }
  Result result = RunMcvo("info --dataset " + Quote(root.string()) + " --cameras image_01,image_00");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("  missing    image_01: 1 (25.0 %)"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("  gaps       1 interval(s) > 1.5x median, largest 0.600 s"),
            std::string::npos)
      << result.output;
  EXPECT_NE(result.output.find("0.600 s after frame 2"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("mark-missing"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("camera 0: image_01"), std::string::npos) << result.output;
  EXPECT_EQ(result.output.find("image_02"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("75.0 % of frames have a pose within 10 ms"), std::string::npos)
      << result.output;

  result = RunMcvo("info --dataset " + Quote(root.string()) + " --skip-incomplete");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("  frames     3,"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("skip-frame: 1 frame(s) dropped"), std::string::npos) << result.output;
}

TEST_F(InfoDataset, BrokenDatasetIsOneLineNamingTheFile) {
  const fs::path root = Synth();
  fs::remove(root / "rig.json");
  for (const std::string format : {"", " --format generic"}) {
    const Result result = RunMcvo("info --dataset " + Quote(root.string()) + format);
    EXPECT_EQ(result.exit_code, 3) << result.output;
    EXPECT_EQ(CountLines(result.output), 1u) << result.output;
    EXPECT_NE(result.output.find("rig.json"), std::string::npos) << result.output;
  }
  const Result missing = RunMcvo("info --dataset " + Quote((dir_ / "nowhere").string()));
  EXPECT_EQ(missing.exit_code, 3) << missing.output;
  EXPECT_EQ(CountLines(missing.output), 1u) << missing.output;
  EXPECT_NE(missing.output.find("nowhere"), std::string::npos) << missing.output;
}

TEST_F(InfoDataset, UsageErrors) {
  const fs::path rig = fs::path(MCVO_SOURCE_DIR) / "config" / "rigs" / "kitti360.json";
  Result result = RunMcvo("info --dataset " + Quote(dir_.string()) + " --rig " + Quote(rig.string()));
  EXPECT_EQ(result.exit_code, 2) << result.output;
  EXPECT_EQ(CountLines(result.output), 1u) << result.output;
  result = RunMcvo("info --rig " + Quote(rig.string()) + " --cameras image_00");
  EXPECT_EQ(result.exit_code, 2) << result.output;
  result = RunMcvo("info --dataset " + Quote(dir_.string()) + " --format tum");
  EXPECT_EQ(result.exit_code, 2) << result.output;
  EXPECT_NE(result.output.find("format"), std::string::npos) << result.output;
  result = RunMcvo("info");
  EXPECT_EQ(result.exit_code, 2) << result.output;
}

// --decode reads every image as `mcvo run` does and prints the time; an
// image that does not decode stops it with the file named and exit 3.
TEST_F(InfoDataset, DecodeReadsEveryImageAndNamesABrokenOne) {
  const fs::path root = Synth();
  Result result = RunMcvo("info --dataset " + Quote(root.string()) + " --decode --threads 2");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("decode: 4 frames, 16 images ("), std::string::npos) << result.output;
  EXPECT_NE(result.output.find(" on 2 threads: "), std::string::npos) << result.output;
  EXPECT_EQ(RunMcvo("info --dataset " + Quote(root.string()) + " --threads 2").exit_code,
            2);  // needs --decode

  // The third frame's image_02 is replaced by text.
  fs::path broken;
  for (const auto& entry : fs::recursive_directory_iterator(root / "images")) {
    const std::string path = entry.path().string();
    if (entry.is_regular_file() && path.find("image_02") != std::string::npos &&
        entry.path().filename().string().find("000002") != std::string::npos) {
      broken = entry.path();
    }
  }
  ASSERT_FALSE(broken.empty());
  {
    FILE* out = std::fopen(broken.c_str(), "wb");
    ASSERT_NE(out, nullptr);
    std::fputs("not a png", out);
    std::fclose(out);
  }
  result = RunMcvo("info --dataset " + Quote(root.string()) + " --decode");
  EXPECT_EQ(result.exit_code, 3) << result.output;
  EXPECT_NE(result.output.find(broken.filename().string()), std::string::npos) << result.output;
}

}  // namespace
