// `mcvo regress` reads only files inside the two run folders (issue 57): a
// run.json whose outputs_sha256 names "../x", "/abs/x" or a symbolic link
// leading outside is bad input (exit 3) and nothing of the outside file is
// printed; a differing line is printed as a bounded, escaped excerpt.
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "mcvo/util/file.h"
#include "test_temp_dir.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::Quote;
using mcvo::test::RunMcvo;

const fs::path kBaseline = fs::path(MCVO_SOURCE_DIR) / "tests" / "data" / "regress_baseline" / "run";
const char kIgnoreBinaryModel[] = " --ignore 'colmap/sparse/0/*'";
const char kSecret[] = "TOP-SECRET-8d1f3c: must never be printed";

fs::path Root() { return mcvo::testing::TestTempDir("regress_confinement_test"); }

fs::path CopyBaseline(const std::string& name) {
  const fs::path out = Root() / name;
  fs::remove_all(out);
  fs::copy(kBaseline, out, fs::copy_options::recursive);
  return out;
}

// A secret file beside the run folders (what "../secret.txt" names from inside one).
fs::path WriteSecret() {
  const fs::path secret = Root() / "secret.txt";
  mcvo::WriteFileAtomic(secret, std::string(kSecret) + "\nsecond line\n");
  return secret;
}

// Adds `file` with a made-up hash to the outputs_sha256 of dir/run.json.
void ListOutput(const fs::path& dir, const std::string& file) {
  nlohmann::json run = nlohmann::json::parse(mcvo::ReadFileToString(dir / "run.json"));
  run["outputs_sha256"][file] = std::string(64, '0');
  mcvo::WriteFileAtomic(dir / "run.json", run.dump(2));
}

mcvo::test::Result Regress(const fs::path& baseline, const fs::path& candidate) {
  return RunMcvo("regress --baseline " + Quote(baseline.string()) + " --candidate " +
                 Quote(candidate.string()) + kIgnoreBinaryModel);
}

size_t LongestLine(const std::string& text) {
  std::istringstream lines(text);
  size_t longest = 0;
  for (std::string line; std::getline(lines, line);) longest = std::max(longest, line.size());
  return longest;
}

TEST(RegressConfinement, UntouchedCopiesAreEqual) {
  // The copies themselves pass, so the failures below are the tampering's.
  const fs::path a = CopyBaseline("plain_a"), b = CopyBaseline("plain_b");
  const auto r = Regress(a, b);
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST(RegressConfinement, ParentPathInOutputsIsBadInput) {
  WriteSecret();
  const fs::path a = CopyBaseline("dotdot_a"), b = CopyBaseline("dotdot_b");
  // On both sides, so that an open of the file would find it and compare it.
  ListOutput(a, "../secret.txt");
  ListOutput(b, "../secret.txt");
  mcvo::WriteFileAtomic(Root() / "other.txt", "differs\n");
  ListOutput(b, "sub/../../other.txt");
  const auto r = Regress(a, b);
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(
      r.output.find((a / "run.json").string() + ": /outputs_sha256/..~1secret.txt: not a relative path"),
      std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("TOP-SECRET"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("second line"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find('\n'), r.output.size() - 1) << "one line:\n" << r.output;

  // ".." inside a path, in the candidate only.
  const fs::path c = CopyBaseline("dotdot_c");
  ListOutput(c, "eval/../../other.txt");
  const auto r2 = Regress(CopyBaseline("dotdot_a2"), c);
  EXPECT_EQ(r2.exit_code, 3) << r2.output;
  EXPECT_NE(r2.output.find("/outputs_sha256/eval~1..~1..~1other.txt"), std::string::npos) << r2.output;
  EXPECT_EQ(r2.output.find("differs"), std::string::npos) << r2.output;
}

TEST(RegressConfinement, AbsolutePathInOutputsIsBadInput) {
  const fs::path secret = WriteSecret();
  for (const std::string& key : {secret.string(), std::string("/etc/hostname")}) {
    const fs::path a = CopyBaseline("abs_a"), b = CopyBaseline("abs_b");
    ListOutput(a, key);
    ListOutput(b, key);
    const auto r = Regress(a, b);
    EXPECT_EQ(r.exit_code, 3) << key << ": " << r.output;
    EXPECT_NE(r.output.find("run.json: /outputs_sha256/~1"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("absolute paths"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("TOP-SECRET"), std::string::npos) << r.output;
  }
}

TEST(RegressConfinement, SymlinkLeadingOutsideIsBadInput) {
  const fs::path secret = WriteSecret();
  const fs::path a = CopyBaseline("link_a"), b = CopyBaseline("link_b");
  // report.md is listed in run.json: in the candidate it becomes a link to
  // the secret, which differs from the baseline's report.md.
  fs::remove(b / "report.md");
  fs::create_symlink(secret, b / "report.md");
  auto r = Regress(a, b);
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find((b).string() + ": report.md leads outside the run folder"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("TOP-SECRET"), std::string::npos) << r.output;

  // A linked folder leading outside, relative link.
  const fs::path c = CopyBaseline("link_c");
  fs::create_directories(Root() / "outside_eval");
  fs::copy(c / "eval", Root() / "outside_eval",
           fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  mcvo::WriteFileAtomic(Root() / "outside_eval" / "eval.md", std::string(kSecret) + "\n");
  fs::remove_all(c / "eval");
  fs::create_directory_symlink("../outside_eval", c / "eval");
  r = Regress(a, c);
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("leads outside the run folder"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("TOP-SECRET"), std::string::npos) << r.output;

  // A link that stays inside the run folder is read as before.
  const fs::path d = CopyBaseline("link_d");
  fs::rename(d / "report.md", d / "report_copy.md");
  fs::create_symlink("report_copy.md", d / "report.md");
  r = Regress(a, d);
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST(RegressConfinement, LongDifferingLineIsBoundedAndEscaped) {
  const fs::path a = CopyBaseline("long_a"), b = CopyBaseline("long_b");
  std::string text = mcvo::ReadFileToString(b / "report.md");
  const std::string line = "\x1b[2J" + std::string(200000, 'Q') + "\x07";
  text.insert(0, line + "\n");
  mcvo::WriteFileAtomic(b / "report.md", text);
  const auto r = Regress(a, b);
  EXPECT_EQ(r.exit_code, 4) << r.output.substr(0, 2000);
  EXPECT_LT(r.output.size(), 20000u);
  EXPECT_LE(LongestLine(r.output), 500u) << r.output.substr(0, 2000);
  EXPECT_EQ(r.output.find('\x1b'), std::string::npos);
  EXPECT_EQ(r.output.find('\x07'), std::string::npos);
  EXPECT_NE(r.output.find("\\x1b[2J"), std::string::npos) << r.output.substr(0, 2000);
  EXPECT_NE(r.output.find("more bytes]"), std::string::npos) << r.output.substr(0, 2000);
}

}  // namespace
