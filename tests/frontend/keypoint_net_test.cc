#include "mcvo/frontend/keypoint_net.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "mcvo/synth/synthesize.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

const std::string kXFeatModel = MCVO_SHARED_DIR "/models/xfeat_480x640.onnx";
const std::string kSuperPointModel = MCVO_SHARED_DIR "/models/superpoint_layout_random_weights_480x640.onnx";

// ---------------------------------------------------------------------------
// DecodeCellLogits on a hand-built 4 x 5 cell map (network image 40 x 32).

constexpr int kHc = 4, kWc = 5;
constexpr float kNoKeypointLogit = 10.0f;

struct LogitMap {
  cv::Mat map;
  LogitMap() {
    const int dims[] = {65, kHc, kWc};
    map = cv::Mat(3, dims, CV_32F, cv::Scalar(0.0f));
    for (int cy = 0; cy < kHc; ++cy)
      for (int cx = 0; cx < kWc; ++cx) At(64, cx, cy) = kNoKeypointLogit;
  }
  float& At(int channel, int cx, int cy) { return map.ptr<float>(channel)[cy * kWc + cx]; }
  // Sets the logit of network pixel (x, y).
  void Set(int x, int y, float logit) { At((y % 8) * 8 + x % 8, x / 8, y / 8) = logit; }
  // The softmax probability of network pixel (x, y), by hand.
  double Probability(int x, int y) {
    const int cx = x / 8, cy = y / 8;
    double sum = 0.0;
    for (int k = 0; k < 65; ++k) sum += std::exp(static_cast<double>(At(k, cx, cy)));
    return std::exp(static_cast<double>(At((y % 8) * 8 + x % 8, cx, cy))) / sum;
  }
};

// A at (15, 11); B at (17, 11) weaker and within radius 2 of A; C at (15, 19)
// weaker but 8 px away; D at (2, 2) inside a border of 4; E at (33, 28)
// below the 0.015 threshold; F, G at (25, 20), (26, 20) an exact tie.
LogitMap TestMap() {
  LogitMap m;
  m.Set(15, 11, 12.0f);
  m.Set(17, 11, 11.5f);
  m.Set(15, 19, 11.0f);
  m.Set(2, 2, 11.0f);
  m.Set(33, 28, 5.0f);
  m.Set(25, 20, 10.5f);
  m.Set(26, 20, 10.5f);
  return m;
}

std::vector<std::pair<int, int>> Pixels(const Detections& d) {
  std::vector<std::pair<int, int>> out;
  for (const auto& p : d.pixels)
    out.emplace_back(static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y())));
  return out;
}

TEST(DecodeCellLogits, FindsTheChosenPixelsWithTheirSoftmaxProbabilities) {
  LogitMap m = TestMap();
  const CellLogitsDecodeOptions options;  // threshold 0.015, NMS 2, border 4
  const Detections d = DecodeCellLogits(m.map, cv::Mat(), cv::Mat(), options, 1.0, 1.0);
  // B is suppressed by A, D is in the border, E below the threshold, G loses the tie to F.
  const std::vector<std::pair<int, int>> expected = {{15, 11}, {15, 19}, {25, 20}};
  ASSERT_EQ(Pixels(d), expected);
  for (size_t i = 0; i < d.size(); ++i) {
    EXPECT_FLOAT_EQ(d.pixels[i].x(), static_cast<float>(expected[i].first));
    EXPECT_NEAR(d.scores[i], m.Probability(expected[i].first, expected[i].second), 1e-6);
  }
  EXPECT_GT(d.scores[0], d.scores[1]);
  EXPECT_TRUE(d.descriptors.empty());
  // By hand: A's cell holds A (e^12), B is in the next cell; 63 zeros and e^10.
  EXPECT_NEAR(d.scores[0], std::exp(12.0) / (63.0 + std::exp(12.0) + std::exp(10.0)), 1e-6);
}

TEST(DecodeCellLogits, NmsBorderAndThresholdOptions) {
  LogitMap m = TestMap();
  CellLogitsDecodeOptions options;
  options.nms_radius_px = 0;
  options.border_px = 0;
  options.threshold = 0.001f;
  const Detections all = DecodeCellLogits(m.map, cv::Mat(), cv::Mat(), options, 1.0, 1.0);
  // Everything: A, B, C = D (tie: D has the smaller y), F = G, E.
  const std::vector<std::pair<int, int>> expected = {{15, 11}, {17, 11}, {2, 2},  {15, 19},
                                                     {25, 20}, {26, 20}, {33, 28}};
  EXPECT_EQ(Pixels(all), expected);
  EXPECT_NEAR(all.scores.back(), m.Probability(33, 28), 1e-7);

  options.max_keypoints = 2;
  EXPECT_EQ(DecodeCellLogits(m.map, cv::Mat(), cv::Mat(), options, 1.0, 1.0).size(), 2u);

  // A radius of 1 keeps B (2 px from A) but still breaks the F/G tie.
  options.max_keypoints = 0;
  options.nms_radius_px = 1;
  const Detections r1 = DecodeCellLogits(m.map, cv::Mat(), cv::Mat(), options, 1.0, 1.0);
  const std::vector<std::pair<int, int>> expected_r1 = {{15, 11}, {17, 11}, {2, 2},
                                                        {15, 19}, {25, 20}, {33, 28}};
  EXPECT_EQ(Pixels(r1), expected_r1);

  // A threshold between C and A keeps A only (B suppressed).
  options.nms_radius_px = 2;
  options.threshold = static_cast<float>(0.5 * (m.Probability(15, 11) + m.Probability(17, 11)));
  EXPECT_EQ(Pixels(DecodeCellLogits(m.map, cv::Mat(), cv::Mat(), options, 1.0, 1.0)),
            (std::vector<std::pair<int, int>>{{15, 11}}));
}

TEST(DecodeCellLogits, ScalesPixelCentresToTheImage) {
  LogitMap m = TestMap();
  const Detections d = DecodeCellLogits(m.map, cv::Mat(), cv::Mat(), CellLogitsDecodeOptions(), 2.0, 0.5);
  ASSERT_FALSE(d.pixels.empty());
  EXPECT_FLOAT_EQ(d.pixels[0].x(), (15 + 0.5f) * 2.0f - 0.5f);
  EXPECT_FLOAT_EQ(d.pixels[0].y(), (11 + 0.5f) * 0.5f - 0.5f);
}

// A 2-channel descriptor map linear in the cell index: bilinear sampling at
// ((x - 3.5) / 8, (y - 3.5) / 8) reproduces it exactly (clamped at the edges).
cv::Mat LinearDescriptorMap() {
  const int dims[] = {2, kHc, kWc};
  cv::Mat map(3, dims, CV_32F);
  for (int cy = 0; cy < kHc; ++cy)
    for (int cx = 0; cx < kWc; ++cx) {
      map.ptr<float>(0)[cy * kWc + cx] = static_cast<float>(cx + 1);
      map.ptr<float>(1)[cy * kWc + cx] = static_cast<float>(10 * cy + 1);
    }
  return map;
}

TEST(DecodeCellLogits, SamplesDescriptorsBilinearlyAndNormalises) {
  LogitMap m = TestMap();
  CellLogitsDecodeOptions options;
  options.border_px = 0;
  const Detections d = DecodeCellLogits(m.map, LinearDescriptorMap(), cv::Mat(), options, 1.0, 1.0);
  ASSERT_EQ(d.descriptors.rows, static_cast<int>(d.size()));
  ASSERT_EQ(d.descriptors.cols, 2);
  ASSERT_EQ(d.descriptors.type(), CV_32F);
  for (size_t i = 0; i < d.size(); ++i) {
    const int x = static_cast<int>(d.pixels[i].x()), y = static_cast<int>(d.pixels[i].y());
    const double u = std::clamp((x - 3.5) / 8.0, 0.0, kWc - 1.0),
                 v = std::clamp((y - 3.5) / 8.0, 0.0, kHc - 1.0);
    const double a = u + 1.0, b = 10.0 * v + 1.0, n = std::hypot(a, b);
    EXPECT_NEAR(d.descriptors.at<float>(static_cast<int>(i), 0), a / n, 1e-6) << x << "," << y;
    EXPECT_NEAR(d.descriptors.at<float>(static_cast<int>(i), 1), b / n, 1e-6) << x << "," << y;
  }
  // D at (2, 2) is clamped to cell (0, 0): (1, 1) / sqrt(2).
  const auto px = Pixels(d);
  const size_t di = std::find(px.begin(), px.end(), std::make_pair(2, 2)) - px.begin();
  ASSERT_LT(di, d.size());
  EXPECT_NEAR(d.descriptors.at<float>(static_cast<int>(di), 0), std::sqrt(0.5), 1e-6);
}

TEST(DecodeCellLogits, MultipliesByBilinearReliability) {
  LogitMap m = TestMap();
  const int dims[] = {1, kHc, kWc};
  cv::Mat reliability(3, dims, CV_32F);
  for (int cy = 0; cy < kHc; ++cy)
    for (int cx = 0; cx < kWc; ++cx)
      reliability.ptr<float>(0)[cy * kWc + cx] = 0.1f * static_cast<float>(cx + 1);
  CellLogitsDecodeOptions options;
  options.threshold = 0.001f;
  const Detections d = DecodeCellLogits(m.map, cv::Mat(), reliability, options, 1.0, 1.0);
  ASSERT_FALSE(d.pixels.empty());
  // A at (15, 11): u = 1.4375, reliability 0.24375; B at (17, 11): u = 1.6875,
  // reliability 0.26875, which lifts B above A: NMS runs on the final score.
  EXPECT_EQ(Pixels(d)[0], std::make_pair(17, 11));
  EXPECT_NEAR(d.scores[0], m.Probability(17, 11) * 0.1 * (1.6875 + 1.0), 1e-6);
  const auto px = Pixels(d);
  EXPECT_EQ(std::find(px.begin(), px.end(), std::make_pair(15, 11)), px.end());
  // C at (15, 19) keeps its place: u = 1.4375.
  const size_t ci = std::find(px.begin(), px.end(), std::make_pair(15, 19)) - px.begin();
  ASSERT_LT(ci, d.size());
  EXPECT_NEAR(d.scores[ci], m.Probability(15, 19) * 0.1 * (1.4375 + 1.0), 1e-6);
}

// ---------------------------------------------------------------------------
// Output layout check.

TEST(IdentifyLayout, RecognisesXFeatAndSuperPoint) {
  const KeypointNetOutputs x = IdentifyLayout({"output_feats", "output_heatmap", "output_keypoints"},
                                              {{1, 64, 60, 80}, {1, 1, 60, 80}, {1, 65, 60, 80}}, "x.onnx");
  EXPECT_EQ(x.layout, KeypointNetLayout::kXFeat);
  EXPECT_EQ(x.cell_logits, 2);
  EXPECT_EQ(x.descriptors, 0);
  EXPECT_EQ(x.reliability, 1);
  EXPECT_EQ(x.descriptor_size, 64);
  const KeypointNetOutputs s =
      IdentifyLayout({"convDb", "convPb"}, {{1, 256, 60, 80}, {1, 65, 60, 80}}, "s.onnx");
  EXPECT_EQ(s.layout, KeypointNetLayout::kSuperPoint);
  EXPECT_EQ(s.cell_logits, 1);
  EXPECT_EQ(s.descriptors, 0);
  EXPECT_EQ(s.reliability, -1);
  EXPECT_EQ(s.descriptor_size, 256);
}

void ExpectLayoutError(const std::vector<std::string>& names, const std::vector<std::vector<int>>& shapes,
                       const std::string& listed) {
  try {
    IdentifyLayout(names, shapes, "/tmp/model.onnx");
    ADD_FAILURE() << "no error for " << listed;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("/tmp/model.onnx: unsupported output layout", 0), 0u) << what;
    EXPECT_NE(what.find(listed), std::string::npos) << what;
    EXPECT_NE(what.find("expected"), std::string::npos) << what;
  }
}

TEST(IdentifyLayout, RejectsOtherLayoutsListingTheOutputs) {
  ExpectLayoutError({"prob"}, {{1, 1000}}, "prob [1,1000]");
  ExpectLayoutError({"a", "b"}, {{1, 64, 60, 80}, {1, 256, 60, 80}}, "a [1,64,60,80], b [1,256,60,80]");
  ExpectLayoutError({"a", "b"}, {{1, 65, 60, 80}, {1, 256, 30, 40}}, "b [1,256,30,40]");
  ExpectLayoutError({"a", "b", "c"}, {{1, 65, 60, 80}, {1, 64, 60, 80}, {1, 2, 60, 80}}, "c [1,2,60,80]");
}

// ---------------------------------------------------------------------------
// Bad model files.

void ExpectLoadError(const std::string& path, const std::string& reason) {
  try {
    KeypointNetDetector detector(path, FrontendOptions());
    ADD_FAILURE() << "no error for " << path;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(path + ": ", 0), 0u) << what;
    EXPECT_NE(what.find(reason), std::string::npos) << what;
  }
}

TEST(KeypointNetDetector, MissingOrBrokenModelFileIsAnInputError) {
  const fs::path dir = fs::path(::testing::TempDir()) / "mcvo_keypoint_net_test";
  fs::create_directories(dir);
  ExpectLoadError((dir / "missing.onnx").string(), "no such file");
  const fs::path garbage = dir / "garbage.onnx";
  {
    std::ofstream out(garbage, std::ios::binary);
    for (int i = 0; i < 4096; ++i) out.put(static_cast<char>((i * 7919 + 13) % 251));
  }
  ExpectLoadError(garbage.string(), "cannot load ONNX model");
}

// ---------------------------------------------------------------------------
// The shipped models on a rendered synthetic urban image.

class KeypointNetModels : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // One folder per process: ctest runs these tests as parallel processes.
    const fs::path parent =
        fs::path(::testing::TempDir()) / "mcvo_keypoint_net_test" / ("synth_" + std::to_string(::getpid()));
    fs::remove_all(parent);
    fs::create_directories(parent);
    synth::SynthOptions options;
    options.preset = "stereo";
    options.frames = 1;
    options.image_scale = 0.5;
    options.render.samples_per_axis = 1;
    synth::Synthesize(options, parent / "out");
    for (const auto& entry : fs::recursive_directory_iterator(parent / "out" / "images")) {
      if (entry.path().extension() == ".png" && image_.empty()) {
        image_ = cv::imread(entry.path().string(), cv::IMREAD_GRAYSCALE);
      }
    }
  }
  static inline cv::Mat image_;
};

void ExpectSortedUnitDescriptors(const Detections& d, int size) {
  ASSERT_EQ(d.descriptors.rows, static_cast<int>(d.size()));
  ASSERT_EQ(d.descriptors.cols, size);
  ASSERT_EQ(d.descriptors.type(), CV_32F);
  for (size_t i = 0; i < d.size(); ++i) {
    EXPECT_NEAR(cv::norm(d.descriptors.row(static_cast<int>(i))), 1.0, 1e-4);
    if (i > 0) {
      EXPECT_GE(d.scores[i - 1], d.scores[i]);
    }
  }
}

bool Identical(const Detections& a, const Detections& b) {
  return a.pixels == b.pixels && a.scores == b.scores && a.descriptors.size() == b.descriptors.size() &&
         cv::norm(a.descriptors, b.descriptors, cv::NORM_INF) == 0.0;
}

TEST_F(KeypointNetModels, XFeatDetectsDeterministically) {
  ASSERT_FALSE(image_.empty());
  KeypointNetDetector detector(kXFeatModel, FrontendOptions());
  EXPECT_EQ(detector.layout(), KeypointNetLayout::kXFeat);
  EXPECT_EQ(detector.DescriptorSize(), 64);
  EXPECT_EQ(detector.input_size(), cv::Size(640, 480));
  EXPECT_EQ(detector.Name(), "xfeat(xfeat_480x640.onnx)");

  cv::Mat mask(image_.size(), CV_8UC1, cv::Scalar(255));
  mask.colRange(0, image_.cols / 3).setTo(0);
  const int border = 10;
  const auto start = std::chrono::steady_clock::now();
  const Detections d = detector.Detect(image_, mask, -1, border);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::printf("xfeat: %zu keypoints on a %dx%d image (2/3 unmasked), %.1f ms per Detect\n", d.size(),
              image_.cols, image_.rows, ms);
  EXPECT_GT(d.size(), 200u);
  ExpectSortedUnitDescriptors(d, 64);
  for (const auto& p : d.pixels) {
    EXPECT_NE(mask.at<uint8_t>(cvRound(p.y()), cvRound(p.x())), 0) << p.transpose();
    EXPECT_GE(p.x(), border);
    EXPECT_GE(p.y(), border);
    EXPECT_LE(p.x(), image_.cols - 1 - border);
    EXPECT_LE(p.y(), image_.rows - 1 - border);
  }

  EXPECT_TRUE(Identical(d, detector.Detect(image_, mask, -1, border)));
  KeypointNetDetector other(kXFeatModel, FrontendOptions());
  EXPECT_TRUE(Identical(d, other.Detect(image_, mask, -1, border)));

  // A cap of 50: the best 50 (the uncapped list's first 50), then up to 50
  // spread extras from the rest, with their scores and descriptors.
  const Detections capped = other.Detect(image_, mask, 50, border);
  ASSERT_GT(capped.size(), 50u);
  ASSERT_LE(capped.size(), 100u);
  ExpectSortedUnitDescriptors(capped, 64);
  EXPECT_EQ(std::vector<float>(capped.scores.begin(), capped.scores.begin() + 50),
            std::vector<float>(d.scores.begin(), d.scores.begin() + 50));
  for (size_t i = 0; i < capped.size(); ++i) {
    const auto it = std::find(d.pixels.begin(), d.pixels.end(), capped.pixels[i]);
    ASSERT_NE(it, d.pixels.end()) << capped.pixels[i].transpose();
    const int row = static_cast<int>(it - d.pixels.begin());
    EXPECT_EQ(d.scores[static_cast<size_t>(row)], capped.scores[i]);
    EXPECT_EQ(cv::norm(d.descriptors.row(row), capped.descriptors.row(static_cast<int>(i)), cv::NORM_L2), 0.0);
  }
}

TEST_F(KeypointNetModels, SuperPointLayoutRuns) {
  ASSERT_FALSE(image_.empty());
  KeypointNetDetector detector(kSuperPointModel, FrontendOptions());
  EXPECT_EQ(detector.layout(), KeypointNetLayout::kSuperPoint);
  EXPECT_EQ(detector.DescriptorSize(), 256);
  const Detections d = detector.Detect(image_, cv::Mat(), 500, 4);
  std::printf("superpoint (random weights): %zu keypoints\n", d.size());
  EXPECT_LE(d.size(), 1000u);  // the best 500 and up to 500 spread extras
  ExpectSortedUnitDescriptors(d, 256);
}

}  // namespace
}  // namespace mcvo
