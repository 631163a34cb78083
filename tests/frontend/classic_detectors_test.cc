#include <algorithm>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "mcvo/frontend/detector.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr int kSquare = 20;
constexpr int kOffset = 10;  // first square edge between pixels 9 and 10

// Checkerboard whose interior corners lie at x, y = kOffset + k * kSquare - 0.5
// (pixel centres at integers), lightly blurred (symmetric, so the corners stay).
cv::Mat Checkerboard(int width, int height) {
  cv::Mat image(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const int cx = (x + kSquare - kOffset) / kSquare;
      const int cy = (y + kSquare - kOffset) / kSquare;
      image.at<uint8_t>(y, x) = ((cx + cy) % 2) ? 200 : 50;
    }
  }
  cv::GaussianBlur(image, image, cv::Size(5, 5), 1.0);
  return image;
}

double DistanceToNearestCorner(const Eigen::Vector2f& p) {
  const auto nearest = [](float v) {
    return std::round((v + 0.5 - kOffset) / kSquare) * kSquare + kOffset - 0.5;
  };
  return std::hypot(p.x() - nearest(p.x()), p.y() - nearest(p.y()));
}

cv::Mat RandomBlocks(int width, int height, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pos_x(0, width - 1), pos_y(0, height - 1), side(8, 40), grey(0, 255);
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(128));
  for (int i = 0; i < 150; ++i) {
    const int x = pos_x(rng), y = pos_y(rng), w = side(rng), h = side(rng);
    cv::rectangle(image, cv::Rect(x, y, w, h), cv::Scalar(grey(rng)), cv::FILLED);
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.7);
  return image;
}

std::unique_ptr<Detector> Make(DetectorType type) {
  FrontendOptions options;
  options.detector = type;
  return CreateDetector(options);
}

void ExpectSortedAndAdmissible(const Detections& d, const cv::Mat& image, const cv::Mat& mask, int border) {
  ASSERT_EQ(d.pixels.size(), d.scores.size());
  for (size_t i = 0; i < d.size(); ++i) {
    const Eigen::Vector2f& p = d.pixels[i];
    EXPECT_GE(p.x(), border);
    EXPECT_GE(p.y(), border);
    EXPECT_LE(p.x(), image.cols - 1 - border);
    EXPECT_LE(p.y(), image.rows - 1 - border);
    if (!mask.empty()) {
      EXPECT_NE(mask.at<uint8_t>(static_cast<int>(std::lround(p.y())), static_cast<int>(std::lround(p.x()))),
                0);
    }
    if (i == 0) continue;
    const Eigen::Vector2f& q = d.pixels[i - 1];
    EXPECT_GE(d.scores[i - 1], d.scores[i]);
    if (d.scores[i - 1] == d.scores[i]) {
      EXPECT_TRUE(q.y() < p.y() || (q.y() == p.y() && q.x() <= p.x()));
    }
  }
}

void ExpectSame(const Detections& a, const Detections& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.pixels[i], b.pixels[i]);
    EXPECT_EQ(a.scores[i], b.scores[i]);
  }
  ASSERT_EQ(a.descriptors.size(), b.descriptors.size());
  if (!a.descriptors.empty()) {
    EXPECT_EQ(cv::norm(a.descriptors, b.descriptors, cv::NORM_HAMMING), 0.0);
  }
}

TEST(ShiTomasiTest, FindsCheckerboardCornersToSubpixel) {
  const cv::Mat image = Checkerboard(240, 180);
  auto detector = Make(DetectorType::kShiTomasi);
  EXPECT_EQ(detector->Name(), "shi_tomasi");
  EXPECT_EQ(detector->DescriptorSize(), 0);
  const Detections d = detector->Detect(image, cv::Mat(), 1000, 4);
  // Interior corners at least 4 px inside: x in {9.5, ..., 229.5} (12), y in {9.5, ..., 169.5} (9).
  EXPECT_EQ(d.size(), 12u * 9u);
  for (const Eigen::Vector2f& p : d.pixels) EXPECT_LT(DistanceToNearestCorner(p), 1.0) << p.transpose();
  EXPECT_TRUE(d.descriptors.empty());
  ExpectSortedAndAdmissible(d, image, cv::Mat(), 4);
}

TEST(ShiTomasiTest, MaskBorderCapAndOrder) {
  const cv::Mat image = RandomBlocks(320, 240, 1);
  cv::Mat mask(image.size(), CV_8UC1, cv::Scalar(255));
  mask(cv::Rect(100, 50, 120, 100)).setTo(0);
  auto detector = Make(DetectorType::kShiTomasi);
  const Detections all = detector->Detect(image, mask, 100000, 16);
  EXPECT_GT(all.size(), 100u);
  ExpectSortedAndAdmissible(all, image, mask, 16);
  const Detections capped = detector->Detect(image, mask, 50, 16);
  ASSERT_EQ(capped.size(), 50u);
  for (size_t i = 0; i < capped.size(); ++i) EXPECT_EQ(capped.pixels[i], all.pixels[i]);
  EXPECT_EQ(detector->Detect(image, mask, 0, 16).size(), 0u);
  EXPECT_EQ(detector->Detect(cv::Mat(100, 100, CV_8UC1, cv::Scalar(7)), cv::Mat(), 100, 0).size(), 0u);
}

TEST(OrbTest, DescriptorsMaskBorderAndOrder) {
  const cv::Mat image = RandomBlocks(320, 240, 2);
  cv::Mat mask(image.size(), CV_8UC1, cv::Scalar(255));
  mask(cv::Rect(0, 0, 160, 240)).setTo(0);
  auto detector = Make(DetectorType::kOrb);
  EXPECT_EQ(detector->Name(), "orb");
  EXPECT_EQ(detector->DescriptorSize(), 32);
  const Detections d = detector->Detect(image, mask, 200, 8);
  EXPECT_GT(d.size(), 30u);
  EXPECT_LE(d.size(), 200u);
  EXPECT_EQ(d.descriptors.type(), CV_8UC1);
  EXPECT_EQ(d.descriptors.cols, 32);
  EXPECT_EQ(d.descriptors.rows, static_cast<int>(d.size()));
  ExpectSortedAndAdmissible(d, image, mask, 8);
  EXPECT_EQ(detector->Detect(image, mask, 0, 8).size(), 0u);
}

TEST(DetectorTest, DeterministicAndIndependentOfThreadCount) {
  const cv::Mat image = RandomBlocks(640, 480, 3);
  const int threads_before = cv::getNumThreads();
  for (DetectorType type : {DetectorType::kShiTomasi, DetectorType::kOrb}) {
    SCOPED_TRACE(static_cast<int>(type));
    auto detector = Make(type);
    cv::setNumThreads(1);
    const Detections one = detector->Detect(image, cv::Mat(), 400, 10);
    const Detections again = Make(type)->Detect(image, cv::Mat(), 400, 10);
    cv::setNumThreads(2);
    const Detections two = detector->Detect(image, cv::Mat(), 400, 10);
    EXPECT_GT(one.size(), 100u);
    ExpectSame(one, again);
    ExpectSame(one, two);
  }
  cv::setNumThreads(threads_before);
}

TEST(DetectorTest, NetworkWithoutModelIsAnInputError) {
  FrontendOptions options;
  options.detector = DetectorType::kXFeat;
  EXPECT_THROW(CreateDetector(options), InputError);
  options.model_path = "/nonexistent/xfeat.onnx";
  EXPECT_THROW(CreateDetector(options), InputError);
}

}  // namespace
}  // namespace mcvo
