#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "../../src/frontend/classic_detectors.h"
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
  // A cap of 50: the best 50 by score (the uncapped list's first 50), then
  // up to 50 spread extras, all in score order.
  const Detections capped = detector->Detect(image, mask, 50, 16);
  ASSERT_GT(capped.size(), 50u);
  ASSERT_LE(capped.size(), 100u);
  ExpectSortedAndAdmissible(capped, image, mask, 16);
  for (size_t i = 0; i < 50; ++i) EXPECT_EQ(capped.pixels[i], all.pixels[i]);
  for (size_t i = 50; i < capped.size(); ++i) {
    const auto it = std::find(all.pixels.begin(), all.pixels.end(), capped.pixels[i]);
    ASSERT_NE(it, all.pixels.end()) << capped.pixels[i].transpose();
    EXPECT_GE(it - all.pixels.begin(), 50);
    EXPECT_EQ(all.scores[static_cast<size_t>(it - all.pixels.begin())], capped.scores[i]);
  }
  EXPECT_EQ(detector->Detect(image, mask, 0, 16).size(), 0u);
  EXPECT_EQ(detector->Detect(cv::Mat(100, 100, CV_8UC1, cv::Scalar(7)), cv::Mat(), 100, 0).size(), 0u);
}

// Strong corners on the left, a weak texture (10 grey levels) on the right,
// sensor noise (sigma 2 grey levels) everywhere: a cap far below the number
// of strong corners still gives the right half candidates, while a flat band
// with noise only gets none.
TEST(ShiTomasiTest, WeakTextureBesideStrongCornersKeepsCandidatesNoiseDoesNot) {
  const int width = 480, height = 240;
  cv::Mat image = Checkerboard(width, height);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 2.0);
  std::uniform_int_distribution<int> grey(120, 130);
  cv::Mat weak(height, width / 2, CV_8UC1);
  for (int y = 0; y < weak.rows; y += 6) {
    for (int x = 0; x < weak.cols; x += 6) weak(cv::Rect(x, y, 6, 6) & cv::Rect(0, 0, weak.cols, weak.rows)) = grey(rng);
  }
  cv::GaussianBlur(weak, weak, cv::Size(3, 3), 0.7);
  weak.copyTo(image(cv::Rect(width / 2, 0, width / 2, height)));
  image(cv::Rect(width / 2, 180, width / 2, height - 180)) = 125;  // flat band
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      image.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(image.at<uint8_t>(y, x) + noise(rng));
    }
  }
  auto detector = Make(DetectorType::kShiTomasi);
  const Detections all = detector->Detect(image, cv::Mat(), 100000, 4);
  const Detections capped = detector->Detect(image, cv::Mat(), 60, 4);
  ASSERT_EQ(capped.size(), 120u);  // the best 60 and 60 spread extras
  ExpectSortedAndAdmissible(capped, image, cv::Mat(), 4);
  const auto count = [](const Detections& d, const cv::Rect& region, size_t begin = 0) {
    return std::count_if(d.pixels.begin() + static_cast<std::ptrdiff_t>(begin), d.pixels.end(),
                         [&](const Eigen::Vector2f& p) { return region.contains(cv::Point(p.x(), p.y())); });
  };
  const cv::Rect left(0, 0, width / 2, height), weak_part(width / 2 + 4, 0, width / 2 - 4, 170),
      noisy(width / 2 + 4, 190, width / 2 - 8, height - 190);
  // The weak texture is far below 1 % of the checkerboard's response, yet
  // detected; the best 60 are all checkerboard corners, and the extras
  // spread over the weak half too.
  EXPECT_GT(count(all, weak_part), 100);
  EXPECT_EQ(count(capped, left), count(capped, left, 60) + 60);
  EXPECT_GE(count(capped, weak_part, 60), 15);
  // The noise band stays below the noise floor.
  EXPECT_EQ(count(all, noisy), 0);
}

// Detections on a 320 x 160 image (cells of 28 px): ten strong points in
// cell (0, 0) (indices 0..9, scores 100..91), one weak point in each of
// cells 1..4 of row 0 (indices 10..13, scores 1..4).
struct PointSet {
  std::vector<Eigen::Vector2f> pixels;
  std::vector<float> scores;
};
PointSet StrongCornerAndWeakCells() {
  PointSet set;
  for (int k = 0; k < 10; ++k) {
    set.pixels.emplace_back(2.0f + k, 3.0f);
    set.scores.push_back(100.0f - k);
  }
  for (int c = 1; c <= 4; ++c) {
    set.pixels.emplace_back(28.0f * c + 5.0f, 5.0f);
    set.scores.push_back(1.0f * c);
  }
  return set;
}

TEST(CapWithSpreadExtrasTest, TheTopByScoreThenSpreadExtras) {
  // StrongCornerAndWeakCells and a second weak point in cell 1 (index 14).
  auto [pixels, scores] = StrongCornerAndWeakCells();
  pixels.emplace_back(40.0f, 20.0f);
  scores.push_back(0.5f);
  // Cap 3: the best three (0, 1, 2), then three extras by cell rank: the
  // best of cells 0 (3), 4 (13) and 3 (12); in score order.
  EXPECT_EQ(internal::CapWithSpreadExtras(pixels, scores, 3, 320, 160), (std::vector<int>{0, 1, 2, 3, 13, 12}));
  // Cap 12: the best twelve and the three left over.
  EXPECT_EQ(internal::CapWithSpreadExtras(pixels, scores, 12, 320, 160).size(), 15u);
  EXPECT_TRUE(internal::CapWithSpreadExtras(pixels, scores, 0, 320, 160).empty());
}

// CapWithSpreadExtras by its definition: every detection sorted, the top
// max_candidates, then SpatiallyBalancedOrder over the others (indices kept
// in input order, so its ties by index are the same).
std::vector<int> CapByDefinition(const std::vector<Eigen::Vector2f>& pixels, const std::vector<float>& scores,
                                 int cap, int width, int height) {
  const int n = static_cast<int>(pixels.size());
  std::vector<int> order = internal::SpatiallyBalancedOrder(pixels, scores, n, width, height);
  if (n <= cap) return order;
  std::vector<bool> top(pixels.size(), false);
  for (int k = 0; k < cap; ++k) top[static_cast<size_t>(order[static_cast<size_t>(k)])] = true;
  order.resize(static_cast<size_t>(cap));
  std::vector<int> rest;
  std::vector<Eigen::Vector2f> rest_pixels;
  std::vector<float> rest_scores;
  for (int i = 0; i < n; ++i) {
    if (top[static_cast<size_t>(i)]) continue;
    rest.push_back(i);
    rest_pixels.push_back(pixels[static_cast<size_t>(i)]);
    rest_scores.push_back(scores[static_cast<size_t>(i)]);
  }
  for (int k : internal::SpatiallyBalancedOrder(rest_pixels, rest_scores, cap, width, height)) {
    order.push_back(rest[static_cast<size_t>(k)]);
  }
  return order;
}

TEST(CapWithSpreadExtrasTest, SameAsSortingEveryDetection) {
  // Random detections, bunched in one corner for some seeds, with tied
  // scores and tied positions, against caps from 1 to more than there are.
  for (unsigned seed = 1; seed <= 40; ++seed) {
    std::mt19937 rng(seed);
    const int width = 300 + static_cast<int>(rng() % 900), height = 100 + static_cast<int>(rng() % 400);
    const int n = static_cast<int>(rng() % 3000);
    const bool bunched = seed % 3 == 0;
    std::vector<Eigen::Vector2f> pixels;
    std::vector<float> scores;
    for (int i = 0; i < n; ++i) {
      const float fx = static_cast<float>(rng() % 1000) / 1000.0f, fy = static_cast<float>(rng() % 1000) / 1000.0f;
      const float spread = bunched && i % 4 != 0 ? 0.2f : 1.0f;
      pixels.emplace_back(std::floor(fx * spread * static_cast<float>(width - 1)),
                          std::floor(fy * spread * static_cast<float>(height - 1)));
      scores.push_back(static_cast<float>(rng() % 200));  // many ties
    }
    for (int cap : {1, 7, 64, 160, 400, 1500, 4000}) {
      EXPECT_EQ(internal::CapWithSpreadExtras(pixels, scores, cap, width, height),
                CapByDefinition(pixels, scores, cap, width, height))
          << "seed " << seed << ", " << n << " detections, cap " << cap;
    }
  }
}

TEST(SpatiallyBalancedOrderTest, EveryCellsBestBeforeAnyCellsSecond) {
  // 320 x 160: cells of sqrt(320 * 160 / 64) = 28 px, 12 x 6 cells.
  const internal::CandidateGrid grid(320, 160);
  EXPECT_EQ(grid.side(), 28);
  EXPECT_EQ(grid.cols(), 12);
  EXPECT_EQ(grid.rows(), 6);
  EXPECT_EQ(grid.Rect(11, 5), cv::Rect(308, 140, 12, 20));
  const auto [pixels, scores] = StrongCornerAndWeakCells();
  // All fit: every index, by decreasing score.
  const std::vector<int> all = internal::SpatiallyBalancedOrder(pixels, scores, 100, 320, 160);
  ASSERT_EQ(all.size(), pixels.size());
  for (size_t k = 1; k < all.size(); ++k) EXPECT_GE(scores[all[k - 1]], scores[all[k]]);
  // Cap 6: the five cells' best (0, 10..13), then cell 0's second (1);
  // returned by decreasing score.
  const std::vector<int> six = internal::SpatiallyBalancedOrder(pixels, scores, 6, 320, 160);
  EXPECT_EQ(six, (std::vector<int>{0, 1, 13, 12, 11, 10}));
  // Cap 3: the three best cell winners.
  EXPECT_EQ(internal::SpatiallyBalancedOrder(pixels, scores, 3, 320, 160), (std::vector<int>{0, 13, 12}));
  EXPECT_TRUE(internal::SpatiallyBalancedOrder(pixels, scores, 0, 320, 160).empty());
}

// The cap as first written (sorts and stable sorts, no shortcuts): the
// reference the faster one must equal index for index.
std::vector<int> ReferenceCap(const std::vector<Eigen::Vector2f>& pixels, const std::vector<float>& scores,
                              int cap, int width, int height) {
  const auto sorted = [&](std::vector<int> idx) {
    std::stable_sort(idx.begin(), idx.end(), [&](int a, int b) {
      if (scores[a] != scores[b]) return scores[a] > scores[b];
      if (pixels[a].y() != pixels[b].y()) return pixels[a].y() < pixels[b].y();
      return pixels[a].x() < pixels[b].x();
    });
    return idx;
  };
  std::vector<int> all(pixels.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  const std::vector<int> order = sorted(all);
  if (cap <= 0) return {};
  if (static_cast<int>(order.size()) <= cap) return order;
  const std::vector<int> rest = sorted(std::vector<int>(order.begin() + cap, order.end()));
  const internal::CandidateGrid grid(width, height);
  std::map<int, int> seen;
  std::map<int, int> rank;
  for (int i : rest) rank[i] = seen[grid.Cell(grid.Col(pixels[i].x()), grid.Row(pixels[i].y()))]++;
  std::vector<int> extras = rest;
  std::stable_sort(extras.begin(), extras.end(), [&](int a, int b) { return rank[a] < rank[b]; });
  if (static_cast<int>(extras.size()) > cap) extras.resize(static_cast<size_t>(cap));
  std::vector<int> kept(order.begin(), order.begin() + cap);
  kept.insert(kept.end(), extras.begin(), extras.end());
  std::map<int, int> position;
  for (size_t k = 0; k < order.size(); ++k) position[order[k]] = static_cast<int>(k);
  std::sort(kept.begin(), kept.end(), [&](int a, int b) { return position[a] < position[b]; });
  return kept;
}

TEST(CapWithSpreadExtrasTest, EqualsTheReferenceWithTiesOfScoreAndPlace) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 600);
    std::vector<Eigen::Vector2f> pixels;
    std::vector<float> scores;
    for (int i = 0; i < n; ++i) {
      // Few distinct values: ties of score, of y and of (score, y, x).
      pixels.emplace_back(static_cast<float>(rng() % 40) * 8.0f, static_cast<float>(rng() % 20) * 8.0f);
      scores.push_back(static_cast<float>(rng() % 12));
    }
    for (const int cap : {0, 1, 7, n / 3, n, n + 5}) {
      EXPECT_EQ(internal::CapWithSpreadExtras(pixels, scores, cap, 320, 160),
                ReferenceCap(pixels, scores, cap, 320, 160))
          << "trial " << trial << " cap " << cap;
    }
  }
}

TEST(RankedValueTest, EqualsNthElement) {
  std::mt19937 rng(3);
  std::vector<uint32_t> histogram;
  for (int trial = 0; trial < 30; ++trial) {
    const size_t n = 1 + rng() % 5000;
    std::vector<float> values;
    for (size_t i = 0; i < n; ++i) {
      switch (rng() % 5) {
        case 0:  // ties
          values.push_back(static_cast<float>(rng() % 10));
          break;
        case 1:  // negatives
          values.push_back(-static_cast<float>(rng() % 1000) * 1e-3f);
          break;
        case 2:  // both zeros
          values.push_back(rng() % 2 ? 0.0f : -0.0f);
          break;
        case 3:  // a wide range
          values.push_back(std::ldexp(1.0f, static_cast<int>(rng() % 60) - 30));
          break;
        default:
          values.push_back(static_cast<float>(rng()) * 1e-9f);
          break;
      }
    }
    for (const size_t rank : {size_t{0}, n / 2, n - 1, rng() % n}) {
      std::vector<float> copy = values;
      std::nth_element(copy.begin(), copy.begin() + static_cast<std::ptrdiff_t>(rank), copy.end());
      const std::vector<float> before = values;
      EXPECT_EQ(internal::RankedValue(values, rank, &histogram), copy[rank]) << "trial " << trial << " rank " << rank;
      EXPECT_EQ(values, before);  // not reordered
    }
  }
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
