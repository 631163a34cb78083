// Camera names become folder names of the outputs (images/<camera>/,
// colmap/images/<camera>/, synth's images/<camera>/ and masks/<camera>.png).
// A rig whose camera is named "../../pwned" must not make `mcvo run` or
// `mcvo synth` write outside --out: both stop with exit 3 and one error line
// naming rig.json and the JSON pointer, before anything is written (issue
// 57). Each case lists the whole scratch folder before and after the command.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "mcvo/util/file.h"
#include "tools/fixture_cache.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::Quote;
using mcvo::test::Result;
using mcvo::test::RunMcvoWithin;
using mcvo::test::SmallMonoRender;

constexpr int kLimitSeconds = 120;

fs::path Scratch() {
  static const fs::path dir = mcvo::test::ProcessScratch("mcvo_hostile_names_test");
  return dir;
}

void Write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}

// Every path under `root` (folders included), relative to it.
std::set<std::string> ListAll(const fs::path& root) {
  std::set<std::string> paths;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(root))
    paths.insert(entry.path().lexically_relative(root).generic_string());
  return paths;
}

// What the command added to or removed from the scratch folder.
std::vector<std::string> Changes(const std::set<std::string>& before, const std::set<std::string>& after) {
  std::vector<std::string> changes;
  for (const std::string& p : after)
    if (before.count(p) == 0) changes.push_back("+ " + p);
  for (const std::string& p : before)
    if (after.count(p) == 0) changes.push_back("- " + p);
  return changes;
}

std::string Join(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& line : lines) out += line + "\n";
  return out;
}

// The lines of the output that are not empty.
std::vector<std::string> Lines(const std::string& output) {
  std::vector<std::string> lines;
  size_t start = 0;
  while (start < output.size()) {
    size_t end = output.find('\n', start);
    if (end == std::string::npos) end = output.size();
    if (end > start) lines.push_back(output.substr(start, end - start));
    start = end + 1;
  }
  return lines;
}

// The base rig with its camera renamed to `json_name` (JSON string contents).
std::string RigNamed(const std::string& json_name) {
  const std::string rig = mcvo::ReadFileToString(SmallMonoRender() / "rig.json");
  const std::string renamed =
      std::regex_replace(rig, std::regex("\"name\": \"[^\"]*\""), "\"name\": \"" + json_name + "\"",
                         std::regex_constants::format_first_only);
  EXPECT_NE(renamed, rig);
  return renamed;
}

// A generic dataset in `dir`: the base rig with the camera named `json_name`
// (as written in JSON) and frames.csv listing the base images by absolute
// path under the header name `csv_name`, so the camera's name is never a
// folder of the input and only the outputs could use it as one.
void MakeDataset(const fs::path& dir, const std::string& json_name, const std::string& csv_name) {
  Write(dir / "rig.json", RigNamed(json_name));
  std::istringstream in(mcvo::ReadFileToString(SmallMonoRender() / "frames.csv"));
  std::string line;
  std::string frames;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      frames += "t_ns," + csv_name + "\n";
      header = false;
      continue;
    }
    const size_t comma = line.find(',');
    ASSERT_NE(comma, std::string::npos) << line;
    frames += line.substr(0, comma + 1) +
              (SmallMonoRender() / line.substr(comma + 1)).lexically_normal().string() + "\n";
  }
  Write(dir / "frames.csv", frames);
}

struct Outcome {
  Result result;
  std::vector<std::string> changes;
};

Outcome RunIn(const std::string& args) {
  const std::set<std::string> before = ListAll(Scratch());
  Outcome outcome;
  outcome.result = RunMcvoWithin(kLimitSeconds, args);
  outcome.changes = Changes(before, ListAll(Scratch()));
  return outcome;
}

TEST(HostileNamesCli, RunRefusesACameraNamedToClimbOutOfOut) {
  ASSERT_FALSE(SmallMonoRender().empty());
  const fs::path parent = Scratch() / "run" / "a" / "b";
  const fs::path data = parent / "data";
  MakeDataset(data, "../../../pwned", "../../../pwned");
  const fs::path out = parent / "out";
  const Outcome o = RunIn("run --dataset " + Quote(data.string()) + " --out " + Quote(out.string()));
  EXPECT_EQ(o.result.exit_code, 3) << o.result.output;
  const std::vector<std::string> lines = Lines(o.result.output);
  ASSERT_EQ(lines.size(), 1u) << o.result.output;
  EXPECT_NE(lines[0].find((data / "rig.json").string() +
                          ": /cameras/0/name: \"../../../pwned\" is not a safe folder name: must not "
                          "contain '/'"),
            std::string::npos)
      << lines[0];
  // Nothing at all written anywhere: not beside --out, not even --out.
  EXPECT_TRUE(o.changes.empty()) << Join(o.changes);
}

TEST(HostileNamesCli, RunKeepsANewlineInTheNameOnOneLine) {
  ASSERT_FALSE(SmallMonoRender().empty());
  const fs::path parent = Scratch() / "newline" / "a" / "b";
  const fs::path data = parent / "data";
  MakeDataset(data, "cam\\nmcvo run: done", "cam");
  const Outcome o =
      RunIn("run --dataset " + Quote(data.string()) + " --out " + Quote((parent / "out").string()));
  EXPECT_EQ(o.result.exit_code, 3) << o.result.output;
  const std::vector<std::string> lines = Lines(o.result.output);
  ASSERT_EQ(lines.size(), 1u) << o.result.output;
  EXPECT_NE(lines[0].find(": /cameras/0/name: \"cam\\nmcvo run: done\" is not a safe folder name: must not "
                          "contain control characters"),
            std::string::npos)
      << lines[0];
  EXPECT_TRUE(o.changes.empty()) << Join(o.changes);
}

TEST(HostileNamesCli, ADatasetWithAPlainNameRunsInfo) {
  // The control of the cases above: the same dataset with an ordinary name
  // (absolute image paths included) is accepted.
  ASSERT_FALSE(SmallMonoRender().empty());
  const fs::path data = Scratch() / "plain" / "data";
  MakeDataset(data, "front", "front");
  const Result r = RunMcvoWithin(kLimitSeconds, "info --dataset " + Quote(data.string()));
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

std::string SynthArgs(const fs::path& rig, const fs::path& out) {
  return "synth --rig " + Quote(rig.string()) +
         " --scene indoor --frames 2 --image-scale 0.1 --samples 1 --out " + Quote(out.string());
}

TEST(HostileNamesCli, SynthRefusesACameraNamedToClimbOutOfOut) {
  ASSERT_FALSE(SmallMonoRender().empty());
  const fs::path parent = Scratch() / "synth" / "a" / "b";
  const fs::path rig = parent / "rig.json";
  Write(rig, RigNamed("../../pwned_synth"));
  const Outcome o = RunIn(SynthArgs(rig, parent / "out2"));
  EXPECT_EQ(o.result.exit_code, 3) << o.result.output;
  const std::vector<std::string> lines = Lines(o.result.output);
  ASSERT_EQ(lines.size(), 1u) << o.result.output;
  EXPECT_NE(lines[0].find(rig.string() +
                          ": /cameras/0/name: \"../../pwned_synth\" is not a safe folder name: must not "
                          "contain '/'"),
            std::string::npos)
      << lines[0];
  EXPECT_TRUE(o.changes.empty()) << Join(o.changes);
}

TEST(HostileNamesCli, SynthWithAPlainNameWritesOnlyIntoOut) {
  // The control: the same rig and command with an ordinary name render, and
  // everything they write is under --out.
  ASSERT_FALSE(SmallMonoRender().empty());
  const fs::path parent = Scratch() / "synth_plain" / "a" / "b";
  const fs::path rig = parent / "rig.json";
  Write(rig, RigNamed("front"));
  const Outcome o = RunIn(SynthArgs(rig, parent / "out2"));
  EXPECT_EQ(o.result.exit_code, 0) << o.result.output;
  EXPECT_TRUE(fs::is_directory(parent / "out2" / "images" / "front")) << Join(o.changes);
  for (const std::string& change : o.changes)
    EXPECT_EQ(change.rfind("+ synth_plain/a/b/out2", 0), 0u) << change;
}

}  // namespace
