#include "mcvo/io/frame_table.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

std::filesystem::path TempFile(const std::string& name, const std::string& content) {
  const auto dir = std::filesystem::path(::testing::TempDir()) / "mcvo_frame_table_test";
  std::filesystem::create_directories(dir);
  const auto path = dir / name;
  WriteFileAtomic(path, content);
  return path;
}

std::string ErrorOf(const std::string& content) {
  try {
    ReadFrameTable(TempFile("bad.csv", content));
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(FrameTable, RoundTripKeepsMissingImages) {
  FrameTable table;
  table.camera_names = {"left", "right"};
  table.rows.push_back({1000, {"images/left/000000.png", "images/right/000000.png"}});
  table.rows.push_back({2000, {"images/left/000001.png", ""}});
  const auto path = TempFile("frames.csv", "");
  WriteFrameTable(path, table);
  EXPECT_EQ(
      ReadFileToString(path),
      "t_ns,left,right\n1000,images/left/000000.png,images/right/000000.png\n2000,images/left/000001.png,\n");
  const FrameTable read = ReadFrameTable(path);
  EXPECT_EQ(read.camera_names, table.camera_names);
  ASSERT_EQ(read.rows.size(), 2u);
  EXPECT_EQ(read.rows[1].t_ns, 2000);
  EXPECT_EQ(read.rows[1].image_paths[0], "images/left/000001.png");
  EXPECT_EQ(read.rows[1].image_paths[1], "");
}

TEST(FrameTable, MalformedFilesNameFileAndLine) {
  EXPECT_NE(ErrorOf("time,a\n").find("bad.csv:1: expected the header"), std::string::npos);
  EXPECT_NE(ErrorOf("t_ns,a,a\n").find("bad.csv:1: camera name \"a\" appears twice"), std::string::npos);
  EXPECT_NE(ErrorOf("t_ns,a,b\n10,x.png\n").find("bad.csv:2: expected 3 comma-separated fields"),
            std::string::npos);
  EXPECT_NE(ErrorOf("t_ns,a\n1.5,x.png\n").find("bad.csv:2: t_ns must be an integer"), std::string::npos);
  EXPECT_NE(
      ErrorOf("t_ns,a\n20,x.png\n# comment\n10,y.png\n").find("bad.csv:4: time 10 ns does not increase"),
      std::string::npos);
  EXPECT_NE(ErrorOf("").find("empty frame table"), std::string::npos);
}

TEST(FrameTable, AUtf8ByteOrderMarkIsSkipped) {
  // Spreadsheet exports start with one; rig.json and groundtruth.tum accept it too.
  const FrameTable table = ReadFrameTable(TempFile("bom.csv", "\xEF\xBB\xBFt_ns,left\n1000,a.png\n"));
  EXPECT_EQ(table.camera_names, std::vector<std::string>{"left"});
  ASSERT_EQ(table.rows.size(), 1u);
  EXPECT_EQ(table.rows[0].image_paths[0], "a.png");
  // Only at the very start: elsewhere the bytes stay part of the field.
  EXPECT_NE(ErrorOf("\n\xEF\xBB\xBFt_ns,a\n").find("bad.csv:2: expected the header"), std::string::npos);
}

TEST(FrameTable, UserTextInErrorsIsEscapedOnOneLine) {
  const std::string error = ErrorOf("t_ns,a\x1B[2J,a\x1B[2J\n");
  EXPECT_NE(error.find("bad.csv:1: camera name \"a\\x1B[2J\" appears twice"), std::string::npos) << error;
  EXPECT_NE(ErrorOf("t_ns,a\n1\x01,x.png\n").find("got \"1\\x01\""), std::string::npos);
}

}  // namespace
}  // namespace mcvo
