#include "mcvo/util/file.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <filesystem>
#include <string>

#include "mcvo/util/error.h"

namespace mcvo {
namespace {

std::filesystem::path TempDir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / ("mcvo_file_test_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(AtomicFileWriter, CommitPublishesCompleteFile) {
  const auto dir = TempDir("commit");
  const auto path = dir / "out.txt";
  {
    AtomicFileWriter writer(path);
    writer.stream() << "hello\n";
    EXPECT_FALSE(std::filesystem::exists(path));  // nothing visible before Commit
    writer.Commit();
  }
  EXPECT_EQ(ReadFileToString(path), "hello\n");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);  // no temporary left
}

TEST(AtomicFileWriter, AbandonedWriteLeavesNoFile) {
  const auto dir = TempDir("abandon");
  const auto path = dir / "out.txt";
  {
    AtomicFileWriter writer(path);
    writer.stream() << "partial";
  }  // e.g. an exception unwound before Commit
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 0);
}

TEST(AtomicFileWriter, UnwritableDirectoryIsAnInputErrorNamingThePath) {
  try {
    WriteFileAtomic("/nonexistent_mcvo_dir/x.txt", "x");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent_mcvo_dir/x.txt"), std::string::npos);
  }
}

TEST(AtomicFileWriter, OpenFailureSaysWhy) {
  try {
    WriteFileAtomic("/nonexistent_mcvo_dir/x.txt", "x");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "/nonexistent_mcvo_dir/x.txt: cannot open for writing: No such file or directory");
  }
}

TEST(AtomicFileWriter, FailedWriteSaysWhy) {
  // A file size limit makes write() fail with EFBIG, as a full disk makes it
  // fail with ENOSPC: the message must carry the system's reason.
  const auto dir = TempDir("limit");
  const auto path = dir / "big.txt";
  struct rlimit saved {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &saved), 0);
  void (*const old_handler)(int) = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit limited = saved;
  limited.rlim_cur = 4096;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &limited), 0);
  std::string what;
  try {
    WriteFileAtomic(path, std::string(200000, 'x'));
  } catch (const InputError& e) {
    what = e.what();
  }
  ::setrlimit(RLIMIT_FSIZE, &saved);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_EQ(what, path.string() + ": write failed: File too large");
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 0);  // no temporary left
}

TEST(AtomicFileWriter, WriteFailedMessageNamesTheReason) {
  EXPECT_EQ(AtomicFileWriter::WriteFailedMessage("out/x.json", ENOSPC),
            "out/x.json: write failed: No space left on device");
  EXPECT_EQ(AtomicFileWriter::WriteFailedMessage("out/x.json", 0), "out/x.json: write failed");
}

TEST(AtomicFileWriter, NeverWritesThroughALinkAtTheTemporaryName) {
  // Someone else's file must not be overwritten through a symbolic link
  // planted where the temporary file goes.
  const auto dir = TempDir("link");
  const auto victim = dir / "victim.txt";
  WriteFileAtomic(victim, "keep me\n");
  const auto path = dir / "out.txt";
  std::filesystem::path tmp = path;
  tmp += ".tmp." + std::to_string(::getpid());
  std::filesystem::create_symlink(victim, tmp);
  try {
    WriteFileAtomic(path, "overwritten\n");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path.string() + ": cannot open for writing: "), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(ReadFileToString(victim), "keep me\n");
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(ReadFileToString, MissingFileNamesThePath) {
  try {
    ReadFileToString("/nonexistent_mcvo_dir/y.txt");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent_mcvo_dir/y.txt"), std::string::npos);
  }
}

}  // namespace
}  // namespace mcvo
