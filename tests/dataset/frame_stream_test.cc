// FrameStream: order and pixels independent of the thread count, bounded
// prefetch, clean early shutdown, and decode errors reported at their frame.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dataset/dataset_fixtures.h"
#include "dataset/forged_images.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;
using testing::CopyDataset;
using testing::SynthDataset;

constexpr char kSuite[] = "frame_stream_test";
constexpr int kFrames = 8;

DatasetIndex Open(const fs::path& root) {
  DatasetOptions options;
  options.root = root;
  return OpenDataset(options);
}

fs::path Stereo() { return SynthDataset(kSuite, "stereo", kFrames); }

// Every frame's index, time and pixel bytes, in stream order.
std::vector<std::string> Drain(const DatasetIndex& index, int threads, int prefetch) {
  FrameStream stream(index, {threads, prefetch});
  std::vector<std::string> frames;
  while (std::optional<FrameImages> frame = stream.Next()) {
    std::string bytes = std::to_string(frame->index) + "@" + std::to_string(frame->t_ns) + ":";
    for (const cv::Mat& image : frame->images) {
      if (image.empty()) {
        bytes += "missing;";
        continue;
      }
      EXPECT_EQ(image.type(), CV_8UC1);
      EXPECT_TRUE(image.isContinuous());
      bytes += std::string(image.ptr<char>(0), image.total()) + ";";
    }
    frames.push_back(std::move(bytes));
  }
  EXPECT_FALSE(stream.Next().has_value());  // stays at the end
  return frames;
}

TEST(FrameStream, SameFramesAtAnyThreadCountAndPrefetch) {
  const DatasetIndex index = Open(Stereo());
  const std::vector<std::string> reference = Drain(index, 1, 1);
  ASSERT_EQ(reference.size(), static_cast<size_t>(kFrames));
  for (int i = 0; i < kFrames; ++i) EXPECT_EQ(reference[i].rfind(std::to_string(i) + "@", 0), 0u);
  // The pixels are the files' pixels.
  const cv::Mat direct = cv::imread(index.frames[3].images[1].string(), cv::IMREAD_GRAYSCALE);
  EXPECT_NE(reference[3].find(std::string(direct.ptr<char>(0), direct.total())), std::string::npos);

  for (const int threads : {1, 2, 4, 0}) {
    for (const int prefetch : {1, 2, 3, 16}) {
      EXPECT_EQ(Drain(index, threads, prefetch), reference) << threads << " threads, prefetch " << prefetch;
    }
  }
}

TEST(FrameStream, MissingImagesAreEmptyMats) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "missing");
  testing::SetCsvField(root / "frames.csv", 3, 1, "");  // frame 2, image_00
  const DatasetIndex index = Open(root);
  FrameStream stream(index, {2, 2});
  for (int i = 0; i < kFrames; ++i) {
    const std::optional<FrameImages> frame = stream.Next();
    ASSERT_TRUE(frame.has_value());
    ASSERT_EQ(frame->images.size(), 2u);
    EXPECT_EQ(frame->images[0].empty(), i == 2);
    EXPECT_FALSE(frame->images[1].empty());
  }
  EXPECT_FALSE(stream.Next().has_value());
}

TEST(FrameStream, EarlyDestructionDoesNotHang) {
  const DatasetIndex index = Open(Stereo());
  const auto start = std::chrono::steady_clock::now();
  for (const int threads : {1, 4}) {
    {
      FrameStream stream(index, {threads, 2});  // never read
    }
    {
      FrameStream stream(index, {threads, 2});
      ASSERT_TRUE(stream.Next().has_value());
    }  // workers blocked on a full ring must still stop
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 30.0);
}

TEST(FrameStream, TruncatedPngThrowsAtItsFrame) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "truncated");
  const fs::path broken = root / "images" / "image_01" / "000004.png";
  const std::string png = testing::ReadText(broken);
  ASSERT_GT(png.size(), 100u);
  testing::WriteText(broken, png.substr(0, 100));
  const DatasetIndex index = Open(root);  // metadata only: still opens
  for (const int threads : {1, 3}) {
    FrameStream stream(index, {threads, 4});
    for (int i = 0; i < 4; ++i) ASSERT_TRUE(stream.Next().has_value()) << i;
    try {
      stream.Next();
      ADD_FAILURE() << "no error for the truncated PNG";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()),
                broken.string() + ": cannot decode image (not an image format OpenCV reads, or truncated)");
    }
    EXPECT_THROW(stream.Next(), InputError);  // the stream stays stopped
  }
}

TEST(FrameStream, WrongImageSizeThrows) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "wrong_size");
  const fs::path broken = root / "images" / "image_00" / "000001.png";
  cv::imwrite(broken.string(), cv::Mat(20, 30, CV_8UC1, cv::Scalar(7)));
  const DatasetIndex index = Open(root);
  FrameStream stream(index, {2, 2});
  ASSERT_TRUE(stream.Next().has_value());
  try {
    stream.Next();
    ADD_FAILURE() << "no error for the wrong image size";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(broken.string() + ": image is 30 x 20 px", 0), 0u) << message;
    EXPECT_NE(message.find("expects 141 x 38"), std::string::npos) << message;
  }
}

// The virtual memory of this process now, in bytes.
uint64_t AddressSpaceBytes() {
  std::ifstream statm("/proc/self/statm");
  uint64_t pages = 0;
  statm >> pages;
  return pages * static_cast<uint64_t>(sysconf(_SC_PAGESIZE));
}

// In a death test's child: exit 0 when the first frame throws `expected`.
[[noreturn]] void DecodeFirstFrameUnderLimit(const DatasetIndex& index, const std::string& expected) {
  const rlimit limit{AddressSpaceBytes() + (uint64_t{300} << 20), RLIM_INFINITY};
  if (setrlimit(RLIMIT_AS, &limit) != 0) std::_Exit(4);
  try {
    FrameStream stream(index, {1, 1});
    stream.Next();
  } catch (const InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    std::_Exit(std::string(e.what()) == expected ? 0 : 2);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    std::_Exit(3);
  }
  std::_Exit(1);
}

// Frame 0 of image_00 replaced by `bytes`: the first Next() must throw the
// size error naming the declared size, in a child process whose address
// space may grow by only 300 MB (the declared image is 900 MB: decoding
// before the check would fail with another message, or not at all).
void ExpectSizeErrorWithoutDecoding(const std::string& name, const std::vector<uint8_t>& bytes,
                                    const std::string& declared) {
  const fs::path root = CopyDataset(Stereo(), kSuite, name);
  const fs::path forged = root / "images" / "image_00" / "000000.png";
  testing::WriteBytes(forged, bytes);
  const DatasetIndex index = Open(root);
  const std::string expected = forged.string() + ": image is " + declared + " px but camera image_00 expects 141 x 38";
  EXPECT_EXIT(DecodeFirstFrameUnderLimit(index, expected), ::testing::ExitedWithCode(0), "") << expected;
}

TEST(FrameStream, ForgedPngSizeFailsFromItsHeader) {
  ExpectSizeErrorWithoutDecoding("forged_png", testing::PngDeclaring(30000, 30000), "30000 x 30000");
}

TEST(FrameStream, ForgedJpegSizeFailsFromItsHeader) {
  ExpectSizeErrorWithoutDecoding("forged_jpeg", testing::JpegDeclaring(30000, 30000), "30000 x 30000");
}

TEST(FrameStream, ImageDeletedAfterOpening) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "deleted");
  const DatasetIndex index = Open(root);
  fs::remove(root / "images" / "image_00" / "000000.png");
  FrameStream stream(index, {1, 1});
  EXPECT_THROW(stream.Next(), InputError);
}

TEST(FrameStream, ColourAnd16BitImagesBecome8BitGrey) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "depths");
  const DatasetIndex index = Open(root);
  const cv::Mat grey = cv::imread(index.frames[0].images[0].string(), cv::IMREAD_GRAYSCALE);
  cv::Mat colour;
  cv::merge(std::vector<cv::Mat>{grey, grey, grey}, colour);
  cv::imwrite(index.frames[0].images[0].string(), colour);
  cv::Mat wide;
  grey.convertTo(wide, CV_16U, 256.0);
  cv::imwrite(index.frames[0].images[1].string(), wide);
  FrameStream stream(index, {1, 1});
  const std::optional<FrameImages> frame = stream.Next();
  ASSERT_TRUE(frame.has_value());
  for (const cv::Mat& image : frame->images) {
    EXPECT_EQ(image.type(), CV_8UC1);
    EXPECT_EQ(cv::norm(image, grey, cv::NORM_INF), 0.0);
  }
}

// keep_decoded: each image's decode beside its grey image, which is
// GreyOfDecodedImage of it; the grey images are the same with or without.
TEST(FrameStream, KeepsTheDecodeBesideTheGreyImage) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "keep");
  const DatasetIndex index = Open(root);
  const cv::Mat grey = cv::imread(index.frames[0].images[0].string(), cv::IMREAD_GRAYSCALE);
  cv::Mat colour;
  cv::merge(std::vector<cv::Mat>{grey, grey / 2, 255 - grey}, colour);
  cv::imwrite(index.frames[0].images[0].string(), colour);
  FrameStreamOptions keep{1, 2};
  keep.keep_decoded = true;
  FrameStream with(index, keep);
  FrameStream without(index, {1, 2});
  const std::optional<FrameImages> a = with.Next(), b = without.Next();
  ASSERT_TRUE(a && b);
  ASSERT_EQ(a->decoded.size(), 2u);
  EXPECT_TRUE(b->decoded.empty());
  EXPECT_EQ(a->decoded[0].type(), CV_8UC3);
  EXPECT_EQ(cv::norm(a->decoded[0], colour, cv::NORM_INF), 0.0);
  EXPECT_EQ(a->decoded[1].type(), CV_8UC1);
  EXPECT_EQ(a->decoded[1].data, a->images[1].data);  // a grey decode is its own grey image
  for (size_t c = 0; c < 2; ++c) {
    EXPECT_EQ(cv::norm(a->images[c], GreyOfDecodedImage(a->decoded[c]), cv::NORM_INF), 0.0) << c;
    EXPECT_EQ(cv::norm(a->images[c], b->images[c], cv::NORM_INF), 0.0) << c;
  }
}

TEST(GreyOfDecodedImage, EachDepthAndLayout) {
  cv::Mat grey(3, 4, CV_8UC1);
  for (int i = 0; i < 12; ++i) grey.at<uint8_t>(i / 4, i % 4) = static_cast<uint8_t>(20 * i + 7);
  EXPECT_EQ(GreyOfDecodedImage(grey).data, grey.data);  // no copy
  EXPECT_TRUE(GreyOfDecodedImage(cv::Mat()).empty());
  // 16-bit: the high byte, whatever the low one (not rounded).
  cv::Mat wide(3, 4, CV_16UC1);
  for (int i = 0; i < 12; ++i) wide.at<uint16_t>(i / 4, i % 4) = static_cast<uint16_t>(256 * (20 * i + 7) + 255);
  EXPECT_EQ(cv::norm(GreyOfDecodedImage(wide), grey, cv::NORM_INF), 0.0);
  // Colour: cv::cvtColor's grey; BGRA: of its colour channels.
  cv::Mat bgr;
  cv::merge(std::vector<cv::Mat>{grey, 255 - grey, grey / 3}, bgr);
  cv::Mat expected;
  cv::cvtColor(bgr, expected, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(cv::norm(GreyOfDecodedImage(bgr), expected, cv::NORM_INF), 0.0);
  cv::Mat bgra;
  cv::merge(std::vector<cv::Mat>{grey, 255 - grey, grey / 3, cv::Mat(3, 4, CV_8UC1, cv::Scalar(9))}, bgra);
  EXPECT_EQ(cv::norm(GreyOfDecodedImage(bgra), expected, cv::NORM_INF), 0.0);
  // 16-bit colour: high bytes, then the grey.
  cv::Mat wide_bgr;
  cv::merge(std::vector<cv::Mat>{wide, wide, wide}, wide_bgr);
  EXPECT_EQ(cv::norm(GreyOfDecodedImage(wide_bgr), grey, cv::NORM_INF), 0.0);
  // Float: converted to 8-bit (rounded, saturated).
  cv::Mat real;
  grey.convertTo(real, CV_32F);
  EXPECT_EQ(cv::norm(GreyOfDecodedImage(real), grey, cv::NORM_INF), 0.0);
}

TEST(FrameStream, BadOptions) {
  const DatasetIndex index = Open(Stereo());
  EXPECT_THROW(FrameStream(index, {1, 0}), UsageError);
  EXPECT_THROW(FrameStream(index, {-1, 2}), UsageError);
}

}  // namespace
}  // namespace mcvo
