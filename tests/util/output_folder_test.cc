// The output discipline (mcvo/util/output_folder.h): what may be written
// where, what may be replaced, the lock, the atomic replace, stale staging.
#include "mcvo/util/output_folder.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

class OutputFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("mcvo_output_folder_test_" + std::to_string(::getpid()) + "_" +
                                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  static void Write(const fs::path& path, const std::string& text) {
    fs::create_directories(path.parent_path());
    std::ofstream(path, std::ios::binary) << text;
  }
  static std::string Read(const fs::path& path) { return ReadFileToString(path); }
  // Every entry below root_, as relative paths.
  std::set<std::string> Listing() const {
    std::set<std::string> names;
    for (const auto& entry : fs::recursive_directory_iterator(root_))
      names.insert(fs::relative(entry.path(), root_).string());
    return names;
  }
  // A finished output of an earlier command at `dir`.
  static void WriteOutput(const fs::path& dir, const std::string& content) {
    OutputFolder out(dir, {});
    Write(out.staging() / "result.txt", content);
    out.Commit();
  }

  fs::path root_;
};

TEST_F(OutputFolderTest, WritesANewFolderWithItsMarkerAndLeavesNothingElse) {
  const fs::path out = root_ / "a" / "out";
  {
    OutputFolderOptions options;
    options.kind = "run";
    OutputFolder folder(out, options);
    EXPECT_EQ(folder.staging().parent_path(), out.parent_path());
    EXPECT_TRUE(fs::is_regular_file(folder.staging() / kStagingMarkerName));
    Write(folder.staging() / "x.txt", "x");
    folder.Commit();
  }
  EXPECT_EQ(Read(out / "x.txt"), "x");
  EXPECT_NE(Read(out / kOutputMarkerName).find("\"run\""), std::string::npos);
  EXPECT_FALSE(fs::exists(out / kStagingMarkerName));
  // No staging folder, no lock file.
  EXPECT_EQ(Listing(), (std::set<std::string>{"a", "a/out", "a/out/x.txt", "a/out/.mcvo-output"}));
}

TEST_F(OutputFolderTest, AnErrorBeforeCommitLeavesTheOldOutputAndNoStaging) {
  const fs::path out = root_ / "out";
  WriteOutput(out, "old");
  const std::set<std::string> before = Listing();
  try {
    OutputFolderOptions options;
    options.force = true;
    OutputFolder folder(out, options);
    Write(folder.staging() / "result.txt", "new, half written");
    throw std::runtime_error("a stage failed");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(Read(out / "result.txt"), "old");
  EXPECT_EQ(Listing(), before);
}

TEST_F(OutputFolderTest, ReplacesAnEarlierOutputOnlyWithForce) {
  const fs::path out = root_ / "out";
  WriteOutput(out, "old");
  EXPECT_THROW(OutputFolder(out, {}), InputError);
  OutputFolderOptions options;
  options.force = true;
  OutputFolder folder(out, options);
  Write(folder.staging() / "new.txt", "new");
  folder.Commit();
  EXPECT_EQ(Read(out / "new.txt"), "new");
  EXPECT_FALSE(fs::exists(out / "result.txt"));  // the old output is gone whole
}

TEST_F(OutputFolderTest, NeverReplacesAFolderMcvoDidNotWriteEvenWithForce) {
  const fs::path out = root_ / "user";
  Write(out / "thesis.tex", "years of work");
  Write(out / "run.json", "{}");  // looks like a run, is not marked as one
  OutputFolderOptions options;
  options.force = true;
  try {
    OutputFolder folder(out, options);
    ADD_FAILURE() << "replaced a folder without the marker";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(kOutputMarkerName), std::string::npos) << e.what();
  }
  EXPECT_EQ(Read(out / "thesis.tex"), "years of work");
  EXPECT_EQ(Listing(), (std::set<std::string>{"user", "user/thesis.tex", "user/run.json"}));
}

TEST_F(OutputFolderTest, FilesThatAppearDuringTheRunAreNotReplaced) {
  const fs::path out = root_ / "out";
  OutputFolder folder(out, {});
  Write(folder.staging() / "x.txt", "x");
  Write(out / "theirs.txt", "written meanwhile by someone else");
  EXPECT_THROW(folder.Commit(), InputError);
  EXPECT_EQ(Read(out / "theirs.txt"), "written meanwhile by someone else");
}

TEST_F(OutputFolderTest, RefusesOutputsThatAreContainOrLieInsideAnInput) {
  const fs::path dataset = root_ / "data" / "seq";
  Write(dataset / "rig.json", "{}");
  for (const fs::path& out : {dataset, root_ / "data", dataset / "runs" / "r1", root_}) {
    OutputFolderOptions options;
    options.force = true;
    options.inputs = {dataset};
    EXPECT_THROW(OutputFolder(out, options), InputError) << out;
  }
  // A file input: the folder may not be the file, nor hold it.
  OutputFolderOptions options;
  options.inputs = {dataset / "rig.json"};
  EXPECT_THROW(OutputFolder(dataset, options), InputError);
  EXPECT_THROW(OutputFolder(dataset / "rig.json", options), InputError);
  EXPECT_EQ(Read(dataset / "rig.json"), "{}");
  // A sibling is fine.
  OutputFolderOptions sibling;
  sibling.inputs = {dataset};
  OutputFolder ok(root_ / "data" / "seq_run", sibling);
  ok.Commit();
}

TEST_F(OutputFolderTest, OverlapSeesThroughSymbolicLinks) {
  const fs::path dataset = root_ / "seq";
  fs::create_directories(dataset);
  fs::create_directory_symlink(dataset, root_ / "alias");
  EXPECT_NE(OverlapWithInput(root_ / "alias", dataset), "");
  EXPECT_NE(OverlapWithInput(root_ / "alias" / "out", dataset), "");
  EXPECT_NE(OverlapWithInput(root_, root_ / "alias"), "");
  EXPECT_EQ(OverlapWithInput(root_ / "other", dataset), "");
  EXPECT_EQ(OverlapWithInput(root_ / "seq2", dataset), "");  // a name prefix is not containment
}

TEST_F(OutputFolderTest, RefusesASymbolicLinkAsTheOutput) {
  fs::create_directories(root_ / "target");
  fs::create_directory_symlink(root_ / "target", root_ / "link");
  EXPECT_THROW(OutputFolder(root_ / "link", {}), InputError);
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status(root_ / "link")));
}

TEST_F(OutputFolderTest, ASecondWriterRefusesAtOnceNamingTheLock) {
  const fs::path out = root_ / "out";
  OutputFolder first(out, {});
  try {
    OutputFolder second(out, {});
    ADD_FAILURE() << "two writers of one output";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("another mcvo"), std::string::npos) << what;
    EXPECT_NE(what.find(".out.lock"), std::string::npos) << what;
    EXPECT_NE(what.find(std::to_string(::getpid())), std::string::npos) << what;
  }
  Write(first.staging() / "x.txt", "x");
  first.Commit();
  EXPECT_EQ(Read(out / "x.txt"), "x");
}

TEST_F(OutputFolderTest, ALockHeldByAnotherProcessRefuses) {
  const fs::path out = root_ / "out";
  const fs::path lock = root_ / ".out.lock";
  const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX), 0);
  EXPECT_THROW(OutputFolder(out, {}), InputError);
  ::flock(fd, LOCK_UN);
  ::close(fd);
  // Released (the file left behind by a killed process): taken.
  {
    OutputFolder folder(out, {});
    folder.Commit();
  }
  EXPECT_FALSE(fs::exists(lock));
}

TEST_F(OutputFolderTest, RemovesStaleStagingOfThisOutputOnly) {
  const fs::path out = root_ / "out";
  // A killed run's staging (marker inside), an old mcvo's (no marker), a user's folder.
  Write(root_ / "out.tmp-999999" / kStagingMarkerName, "out\n");
  Write(root_ / "out.tmp-999999" / "partial.txt", "x");
  Write(root_ / "out.tmp-999998" / "partial.txt", "x");
  Write(root_ / "out.tmp-notes" / kStagingMarkerName, "out\n");
  Write(root_ / "other.tmp-999999" / kStagingMarkerName, "other\n");
  OutputFolder folder(out, {});
  folder.Commit();
  EXPECT_FALSE(fs::exists(root_ / "out.tmp-999999"));
  EXPECT_TRUE(fs::exists(root_ / "out.tmp-999998" / "partial.txt"));
  EXPECT_TRUE(fs::exists(root_ / "out.tmp-notes"));
  EXPECT_TRUE(fs::exists(root_ / "other.tmp-999999"));
}

TEST_F(OutputFolderTest, RestoresTheOldOutputOfAnInterruptedReplace) {
  // Without RENAME_EXCHANGE the replace moves the old output to
  // "<name>.old-<pid>" first; killed there, --out is missing.
  const fs::path out = root_ / "out";
  WriteOutput(out, "old");
  fs::rename(out, root_ / "out.old-999999");
  {
    OutputFolder folder(out, {});
    EXPECT_EQ(Read(out / "result.txt"), "old");  // back in place before anything else
  }
  EXPECT_EQ(Read(out / "result.txt"), "old");
}

TEST_F(OutputFolderTest, LongNamesKeepTheirSiblingsWithinTheFileNameLimit) {
  const std::string name(250, 'x');
  const std::string staging = SiblingName(name, ".tmp-4194304");
  EXPECT_LE(staging.size(), 255u);
  EXPECT_NE(staging, SiblingName(std::string(249, 'x') + "y", ".tmp-4194304"));
  EXPECT_EQ(SiblingName("short", ".tmp-1"), "short.tmp-1");
  // Cut on a character boundary: a run of 2-byte letters.
  std::string letters;
  for (int i = 0; i < 125; ++i) letters += "\xc3\xa9";
  const std::string cut = SiblingName(letters, ".tmp-123");
  EXPECT_LE(cut.size(), 255u);
  EXPECT_NE(static_cast<unsigned char>(cut[cut.find('~') - 1]), 0xc3);
  OutputFolder folder(root_ / name, {});
  folder.Commit();
  EXPECT_TRUE(fs::is_regular_file(root_ / name / kOutputMarkerName));
}

TEST_F(OutputFolderTest, OutputFilesMayNotBeOrLieInsideInputs) {
  const fs::path dataset = root_ / "seq";
  Write(dataset / "rig.json", "{}");
  EXPECT_THROW(CheckOutputFile(dataset / "rig.json", {dataset / "rig.json"}), InputError);
  EXPECT_THROW(CheckOutputFile(dataset / "tracks.bin", {dataset}), InputError);
  EXPECT_THROW(CheckOutputFile(dataset, {}), InputError);  // a folder
  EXPECT_NO_THROW(CheckOutputFile(root_ / "tracks.bin", {dataset}));
}

}  // namespace
}  // namespace mcvo
