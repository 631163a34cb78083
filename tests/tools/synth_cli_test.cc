// `mcvo synth` as a user runs it: exit codes and one-line errors.
#include <gtest/gtest.h>

#include "tools/run_mcvo.h"

#include <sys/wait.h>
#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

#include "mcvo/util/file.h"

namespace {

namespace fs = std::filesystem;

using mcvo::test::Quote;
using mcvo::test::Result;
using mcvo::test::RunMcvo;

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / "mcvo_synth_cli_test" / name;
  fs::remove_all(dir);
  fs::create_directories(dir.parent_path());
  return dir;
}

TEST(SynthCli, WritesASequence) {
  const fs::path out = TempDir("ok");
  const Result r =
      RunMcvo("synth --preset stereo --frames 2 --image-scale 0.1 --samples 1 --out " + out.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out / "frames.csv"));
  EXPECT_TRUE(fs::exists(out / "images/image_01/000001.png"));
}

TEST(SynthCli, BadInputGivesOneLineAndExitCode3) {
  const fs::path out = TempDir("bad");
  Result r = RunMcvo("synth --preset nosuch --out " + out.string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("unknown preset 'nosuch' (known: irregular5, kitti360"), std::string::npos)
      << r.output;

  fs::create_directories(out);
  mcvo::WriteFileAtomic(out / "x.txt", "x");
  r = RunMcvo("synth --preset stereo --frames 1 --out " + out.string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("not empty (use --force"), std::string::npos) << r.output;

  const fs::path rig = out.parent_path() / "broken_rig.json";
  mcvo::WriteFileAtomic(rig, R"({"cameras": []})");
  r = RunMcvo("synth --rig " + rig.string() + " --scene urban --out " +
              (out.parent_path() / "from_rig").string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("broken_rig.json"), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
}

TEST(SynthCli, MisuseGivesExitCode2) {
  const fs::path out = TempDir("usage");
  EXPECT_EQ(RunMcvo("synth --out " + out.string()).exit_code, 2);  // no preset or rig
  EXPECT_EQ(RunMcvo("synth --preset stereo").exit_code, 2);        // no --out
  EXPECT_EQ(RunMcvo("synth --preset stereo --out " + out.string() + " --samples 0").exit_code, 2);
  EXPECT_EQ(RunMcvo("synth --preset stereo --out " + out.string() + " --blackout x").exit_code, 2);
  EXPECT_EQ(RunMcvo("synth --preset stereo --out " + out.string() + " --scene moon").exit_code, 3);
  // The realism flags: malformed, out of range, or sensor noise with --noise.
  for (const char* flags : {"--sensor-noise 0.03", "--sensor-noise a:b", "--sensor-noise -1:0", "--tone 1.5",
                            "--tone 0:1", "--lens-blur -1", "--sensor-noise 0.03:0 --noise 2"}) {
    const Result r = RunMcvo("synth --preset stereo --out " + out.string() + " " + flags);
    EXPECT_EQ(r.exit_code, 2) << flags << ": " << r.output;
  }
  EXPECT_FALSE(fs::exists(out));
}

TEST(SynthCli, RealismFlagsRender) {
  const fs::path out = TempDir("realism");
  const Result r = RunMcvo(
      "synth --preset stereo --frames 1 --image-scale 0.1 --samples 1 --sensor-noise 0.033:0 "
      "--lens-blur 0.8 --tone 1.5:1.5 --out " +
      out.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(mcvo::ReadFileToString(out / "meta.json").find("\"tone\""), std::string::npos);
}

}  // namespace
