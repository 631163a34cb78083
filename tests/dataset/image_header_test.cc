// ReadImageHeader: the size, depth and channels each format's header
// declares, equal to the decode's for files OpenCV writes, and the declared
// size of forged files read without decoding them.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dataset/forged_images.h"
#include "mcvo/dataset/image_file.h"
#include "test_temp_dir.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;
using testing::JpegDeclaring;
using testing::PngDeclaring;
using testing::WriteBytes;

fs::path Dir() {
  static const fs::path dir = [] {
    const fs::path d = testing::TestTempDir("image_header_test");
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

struct Written {
  std::string extension;
  int type;  // of the Mat written
  int bit_depth;
  int channels;
};

TEST(ReadImageHeader, GivesTheSizeOfEveryFormatOpenCvWrites) {
  std::vector<Written> cases = {
      {".png", CV_8UC1, 8, 1},  {".png", CV_16UC1, 16, 1}, {".png", CV_8UC3, 8, 3}, {".png", CV_8UC4, 8, 4},
      {".jpg", CV_8UC1, 8, 1},  {".jpg", CV_8UC3, 8, 3},   {".pgm", CV_8UC1, 8, 1}, {".pgm", CV_16UC1, 16, 1},
      {".ppm", CV_8UC3, 8, 3},  {".bmp", CV_8UC3, 8, 3},   {".bmp", CV_8UC1, 8, 1},
  };
  if (cv::haveImageWriter(".tiff")) {
    cases.push_back({".tiff", CV_8UC1, 8, 1});
    cases.push_back({".tiff", CV_16UC3, 16, 3});
  }
  int i = 0;
  for (const Written& w : cases) {
    const fs::path path = Dir() / ("written_" + std::to_string(i++) + w.extension);
    SCOPED_TRACE(path.string());
    cv::Mat image(37, 53, w.type);
    cv::randu(image, 0, 200);
    ASSERT_TRUE(cv::imwrite(path.string(), image));
    const std::optional<ImageHeader> header = ReadImageHeader(path);
    ASSERT_TRUE(header.has_value());
    const cv::Mat decoded = cv::imread(path.string(), cv::IMREAD_ANYCOLOR | cv::IMREAD_ANYDEPTH);
    EXPECT_EQ(header->width, decoded.cols);
    EXPECT_EQ(header->height, decoded.rows);
    EXPECT_EQ(header->width, 53);
    EXPECT_EQ(header->height, 37);
    if (w.extension != ".bmp" || w.channels == 3) {  // a grey BMP is stored with a palette
      EXPECT_EQ(header->bit_depth, w.bit_depth);
      EXPECT_EQ(header->channels, w.channels);
    }
  }
}

TEST(ReadImageHeader, GivesTheDeclaredSizeOfAForgedPngWithoutDecoding) {
  const fs::path path = Dir() / "huge.png";
  WriteBytes(path, PngDeclaring(30000, 30000));
  EXPECT_LT(fs::file_size(path), 200u);
  const std::optional<ImageHeader> header = ReadImageHeader(path);
  ASSERT_TRUE(header.has_value());
  EXPECT_EQ(std::string(header->format), "png");
  EXPECT_EQ(header->width, 30000);
  EXPECT_EQ(header->height, 30000);
  EXPECT_EQ(header->bit_depth, 8);
  EXPECT_EQ(header->channels, 1);
}

TEST(ReadImageHeader, GivesTheForgedSizeOfAJpegFrameHeader) {
  const fs::path path = Dir() / "forged.jpg";
  WriteBytes(path, JpegDeclaring(30000, 20000, /*colour=*/true));
  const std::optional<ImageHeader> header = ReadImageHeader(path);
  ASSERT_TRUE(header.has_value());
  EXPECT_EQ(std::string(header->format), "jpeg");
  EXPECT_EQ(header->width, 30000);
  EXPECT_EQ(header->height, 20000);
  EXPECT_EQ(header->channels, 3);
}

TEST(ReadImageHeader, NothingForOtherFormatsAndDamagedHeaders) {
  const auto header_of = [](const std::string& name, const std::vector<uint8_t>& bytes) {
    WriteBytes(Dir() / name, bytes);
    return ReadImageHeader(Dir() / name);
  };
  EXPECT_FALSE(header_of("text.png", {'h', 'e', 'l', 'l', 'o', '\n'}).has_value());
  EXPECT_FALSE(header_of("empty.png", {}).has_value());
  EXPECT_FALSE(ReadImageHeader(Dir() / "does_not_exist.png").has_value());
  std::vector<uint8_t> png = PngDeclaring(100, 100);
  png[20] ^= 1;  // the IHDR CRC no longer holds
  EXPECT_FALSE(header_of("bad_crc.png", png).has_value());
  png = PngDeclaring(100, 100);
  png.resize(25);
  EXPECT_FALSE(header_of("cut.png", png).has_value());
  std::vector<uint8_t> jpeg = JpegDeclaring(64, 48);
  jpeg.resize(40);  // before the frame header
  EXPECT_FALSE(header_of("cut.jpg", jpeg).has_value());
  EXPECT_FALSE(header_of("cut.pgm", {'P', '5', '\n', '6', '4', ' '}).has_value());
  const std::string comment = "P5\n# a comment 99 99\n64 48\n255\n";
  const std::optional<ImageHeader> pnm = header_of("comment.pgm", std::vector<uint8_t>(comment.begin(), comment.end()));
  ASSERT_TRUE(pnm.has_value());
  EXPECT_EQ(pnm->width, 64);
  EXPECT_EQ(pnm->height, 48);
}

}  // namespace
}  // namespace mcvo
