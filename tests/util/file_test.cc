#include "mcvo/util/file.h"

#include <gtest/gtest.h>

#include <filesystem>

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
