#include "mcvo/frontend/selection.h"

#include <algorithm>
#include <cstdio>
#include <random>
#include <thread>

#include <gtest/gtest.h>

namespace mcvo {
namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;

Detections RandomCandidates(int n, unsigned seed, float x0 = 0, float x1 = kWidth - 1, float y0 = 0,
                            float y1 = kHeight - 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> ux(x0, x1), uy(y0, y1), us(0.0f, 1.0f);
  Detections d;
  for (int i = 0; i < n; ++i) {
    d.pixels.emplace_back(ux(rng), uy(rng));
    d.scores.push_back(us(rng));
  }
  return d;
}

std::vector<Eigen::Vector2f> RandomPoints(int n, unsigned seed, float x0, float x1, float y0, float y1) {
  return RandomCandidates(n, seed, x0, x1, y0, y1).pixels;
}

SelectionInput MakeInput(const Detections* candidates, std::vector<Eigen::Vector2f> tracked, int max_features,
                         double min_distance) {
  SelectionInput input;
  input.tracked = std::move(tracked);
  input.candidates = candidates;
  input.image_width = kWidth;
  input.image_height = kHeight;
  input.max_features = max_features;
  input.min_distance_px = min_distance;
  return input;
}

const FeatureSelection kMethods[] = {FeatureSelection::kThreePriority, FeatureSelection::kQuadtree,
                                     FeatureSelection::kScore};

std::vector<Eigen::Vector2f> Pixels(const Detections& d, const std::vector<int>& indices) {
  std::vector<Eigen::Vector2f> out;
  for (int i : indices) out.push_back(d.pixels[i]);
  return out;
}

TEST(SelectionTest, RespectsCountAndMinimumDistance) {
  const Detections candidates = RandomCandidates(400, 1);
  const std::vector<Eigen::Vector2f> tracked = RandomPoints(30, 2, 0, kWidth - 1, 0, kHeight - 1);
  for (FeatureSelection method : kMethods) {
    SCOPED_TRACE(static_cast<int>(method));
    const SelectionInput input = MakeInput(&candidates, tracked, 100, 20.0);
    const std::vector<int> chosen = SelectFeatures(input, method);
    EXPECT_LE(chosen.size(), 70u);
    EXPECT_GE(chosen.size(), 40u);  // 640x480 holds many more 20 px discs
    std::vector<int> sorted = chosen;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
    for (size_t a = 0; a < chosen.size(); ++a) {
      ASSERT_GE(chosen[a], 0);
      ASSERT_LT(chosen[a], static_cast<int>(candidates.size()));
      const Eigen::Vector2f& p = candidates.pixels[chosen[a]];
      for (const Eigen::Vector2f& t : tracked) EXPECT_GE((p - t).norm(), 20.0f);
      for (size_t b = a + 1; b < chosen.size(); ++b)
        EXPECT_GE((p - candidates.pixels[chosen[b]]).norm(), 20.0f);
    }
  }
}

TEST(SelectionTest, NothingWantedWhenTrackedFillTheBudget) {
  const Detections candidates = RandomCandidates(100, 3);
  const std::vector<Eigen::Vector2f> tracked = RandomPoints(50, 4, 0, kWidth - 1, 0, kHeight - 1);
  for (FeatureSelection method : kMethods) {
    EXPECT_TRUE(SelectFeatures(MakeInput(&candidates, tracked, 50, 20.0), method).empty());
    EXPECT_TRUE(SelectFeatures(MakeInput(&candidates, tracked, 10, 20.0), method).empty());
  }
}

TEST(SelectionTest, RespectsMask) {
  const Detections candidates = RandomCandidates(400, 5);
  SelectionInput input = MakeInput(&candidates, {}, 100, 10.0);
  input.mask = cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(255));
  input.mask(cv::Rect(0, 0, kWidth / 2, kHeight)).setTo(0);
  input.mask(cv::Rect(400, 100, 100, 100)).setTo(0);
  for (FeatureSelection method : kMethods) {
    const std::vector<int> chosen = SelectFeatures(input, method);
    EXPECT_FALSE(chosen.empty());
    for (const Eigen::Vector2f& p : Pixels(candidates, chosen)) {
      EXPECT_NE(
          input.mask.at<uint8_t>(static_cast<int>(std::lround(p.y())), static_cast<int>(std::lround(p.x()))),
          0);
    }
  }
}

TEST(SelectionTest, ScorePicksHighestScores) {
  // Candidates on a 40 px lattice: no two closer than the minimum distance.
  Detections candidates;
  for (int y = 20; y < kHeight; y += 40) {
    for (int x = 20; x < kWidth; x += 40) {
      candidates.pixels.emplace_back(x, y);
      candidates.scores.push_back(static_cast<float>((x * 7 + y * 13) % 101));
    }
  }
  const std::vector<int> chosen =
      SelectFeatures(MakeInput(&candidates, {}, 25, 20.0), FeatureSelection::kScore);
  ASSERT_EQ(chosen.size(), 25u);
  std::vector<float> sorted_scores = candidates.scores;
  std::sort(sorted_scores.begin(), sorted_scores.end(), std::greater<float>());
  for (size_t i = 0; i < chosen.size(); ++i) EXPECT_EQ(candidates.scores[chosen[i]], sorted_scores[i]);
}

// Tracked features cover the left half (36 px lattice), where the candidates
// also score higher (texture-rich): the 3-priority tree puts the new features
// in the empty right half; the score baseline fills the lattice gaps first.
TEST(SelectionTest, ThreePriorityPrefersEmptyRegions) {
  Detections candidates = RandomCandidates(400, 6);
  for (size_t i = 0; i < candidates.size(); ++i) {
    if (candidates.pixels[i].x() < kWidth / 2) candidates.scores[i] += 1.0f;
  }
  std::vector<Eigen::Vector2f> tracked;
  for (int y = 15; y < kHeight; y += 36) {
    for (int x = 15; x < kWidth / 2; x += 36) tracked.emplace_back(x, y);
  }
  const int max_features = static_cast<int>(tracked.size()) + 50;
  const auto right_fraction = [&](FeatureSelection method) {
    const std::vector<int> chosen =
        SelectFeatures(MakeInput(&candidates, tracked, max_features, 20.0), method);
    EXPECT_GE(chosen.size(), 40u);
    int right = 0;
    for (const Eigen::Vector2f& p : Pixels(candidates, chosen)) right += p.x() >= kWidth / 2 ? 1 : 0;
    return static_cast<double>(right) / std::max<size_t>(chosen.size(), 1);
  };
  const double three = right_fraction(FeatureSelection::kThreePriority);
  const double score = right_fraction(FeatureSelection::kScore);
  std::printf("right-half fraction: three_priority %.2f, quadtree %.2f, score %.2f\n", three,
              right_fraction(FeatureSelection::kQuadtree), score);
  EXPECT_GE(three, 0.8);
  EXPECT_GT(three, score);
}

// Texture-rich corner (dense, high scores) and sparse elsewhere: the tree
// methods spread the features more evenly than the score baseline.
TEST(SelectionTest, TreesSpreadMoreThanScore) {
  Detections candidates = RandomCandidates(300, 8, 0, 200, 0, 150);
  for (float& s : candidates.scores) s += 1.0f;
  const Detections sparse = RandomCandidates(100, 9);
  candidates.pixels.insert(candidates.pixels.end(), sparse.pixels.begin(), sparse.pixels.end());
  candidates.scores.insert(candidates.scores.end(), sparse.scores.begin(), sparse.scores.end());
  const auto sfd = [&](FeatureSelection method) {
    const std::vector<int> chosen = SelectFeatures(MakeInput(&candidates, {}, 60, 10.0), method);
    EXPECT_GE(chosen.size(), 50u);
    return ComputeSfd(Pixels(candidates, chosen), kWidth, kHeight);
  };
  const double score = sfd(FeatureSelection::kScore);
  EXPECT_LT(sfd(FeatureSelection::kThreePriority), score);
  EXPECT_LT(sfd(FeatureSelection::kQuadtree), score);
}

TEST(SelectionTest, DeterministicAcrossThreads) {
  const Detections candidates = RandomCandidates(500, 10);
  const std::vector<Eigen::Vector2f> tracked = RandomPoints(40, 11, 0, kWidth - 1, 0, kHeight - 1);
  const SelectionInput input = MakeInput(&candidates, tracked, 150, 15.0);
  for (FeatureSelection method : kMethods) {
    const std::vector<int> serial = SelectFeatures(input, method);
    std::vector<int> a, b;
    std::thread ta([&] { a = SelectFeatures(input, method); });
    std::thread tb([&] { b = SelectFeatures(input, method); });
    ta.join();
    tb.join();
    EXPECT_EQ(serial, a);
    EXPECT_EQ(serial, b);
  }
}

TEST(SelectionTest, DuplicatePointsDoNotHang) {
  Detections candidates;
  for (int i = 0; i < 50; ++i) {
    candidates.pixels.emplace_back(100.0f, 100.0f);
    candidates.scores.push_back(static_cast<float>(i % 5));
  }
  for (FeatureSelection method : kMethods) {
    const std::vector<int> chosen = SelectFeatures(MakeInput(&candidates, {}, 20, 5.0), method);
    ASSERT_EQ(chosen.size(), 1u);
    EXPECT_EQ(candidates.scores[chosen[0]], 4.0f);
  }
}

TEST(SfdTest, UniformGridIsZero) {
  std::vector<Eigen::Vector2f> pixels;
  for (int r = 0; r < 16; ++r) {
    for (int c = 0; c < 16; ++c)
      pixels.emplace_back((c + 0.5f) * kWidth / 16 - 0.5f, (r + 0.5f) * kHeight / 16 - 0.5f);
  }
  EXPECT_DOUBLE_EQ(ComputeSfd(pixels, kWidth, kHeight), 0.0);
  EXPECT_DOUBLE_EQ(ComputeSfd({}, kWidth, kHeight), 0.0);
}

TEST(SfdTest, ClusterIsLarge) {
  // 64 points in one of 64 cells: counts {64, 0 x 63}, mean 1, variance 63.
  const std::vector<Eigen::Vector2f> pixels = RandomPoints(64, 12, 0, 70, 0, 50);
  EXPECT_NEAR(ComputeSfd(pixels, kWidth, kHeight), 63.0, 1e-9);
  // Outside the image: not counted.
  EXPECT_DOUBLE_EQ(ComputeSfd({Eigen::Vector2f(-5, 10), Eigen::Vector2f(10, kHeight + 3)}, kWidth, kHeight),
                   0.0);
}

}  // namespace
}  // namespace mcvo
