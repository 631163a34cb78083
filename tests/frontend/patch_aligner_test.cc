// The anchor patch alignment (patch_aligner.h): an affine warp with a gain
// and offset of the intensities is recovered to a few hundredths of a
// pixel; another patch, a flat patch and the image border are told apart.
#include "mcvo/frontend/patch_aligner.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace mcvo {
namespace {

// Smooth random texture (blurred uniform noise), 8 bit.
cv::Mat Texture(int width, int height, uint64_t seed) {
  cv::Mat noise(height, width, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 255.0);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 2.0);
  cv::normalize(smooth, smooth, 20.0, 235.0, cv::NORM_MINMAX);
  cv::Mat out;
  smooth.convertTo(out, CV_8U);
  return out;
}

// `image` warped by y = a x + t (cv::warpAffine, bicubic), intensities
// times `gain` plus `offset`.
cv::Mat Warped(const cv::Mat& image, const Eigen::Matrix2f& a, const Eigen::Vector2f& t, double gain,
               double offset) {
  const cv::Mat m = (cv::Mat_<double>(2, 3) << a(0, 0), a(0, 1), t.x(), a(1, 0), a(1, 1), t.y());
  cv::Mat warped;
  cv::warpAffine(image, warped, m, image.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  cv::Mat out;
  warped.convertTo(out, CV_8U, gain, offset);
  return out;
}

std::vector<Eigen::Vector2f> GridPoints(int width, int height, int step, int margin) {
  std::vector<Eigen::Vector2f> points;
  for (int y = margin; y < height - margin; y += step)
    for (int x = margin; x < width - margin; x += step)
      points.emplace_back(static_cast<float>(x) + 0.3f, static_cast<float>(y) + 0.6f);
  return points;
}

TEST(PatchAligner, RecoversAnAffineWarpWithGainAndOffset) {
  const cv::Mat image = Texture(320, 240, 1);
  Eigen::Matrix2f a;
  a << 1.08f, 0.05f, -0.04f, 0.95f;  // zoom, shear, a small rotation
  const Eigen::Vector2f t(-6.3f, 4.7f);
  const cv::Mat next = Warped(image, a, t, 1.2, -15.0);
  const PatchAlignOptions options;
  std::vector<double> errors;
  int aligned = 0, anchors = 0;
  for (const Eigen::Vector2f& p : GridPoints(image.cols, image.rows, 23, 40)) {
    const PatchAnchor anchor = MakePatchAnchor(image, p, options);
    if (!anchor.valid) continue;
    ++anchors;
    const Eigen::Vector2f truth = a * p + t;
    // LK's position is off by most of a pixel; the warp starts at identity.
    const PatchAlignResult r = AlignPatch(anchor, next, truth + Eigen::Vector2f(0.7f, -0.5f), options);
    if (r.status != PatchAlignStatus::kAligned) continue;
    ++aligned;
    errors.push_back((r.pixel - truth).norm());
    EXPECT_GT(r.zncc, 0.95);
    EXPECT_LT((r.warp - a).cwiseAbs().maxCoeff(), 0.03f);
  }
  ASSERT_GT(anchors, 50);
  EXPECT_GE(aligned, anchors * 95 / 100);
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.03);
  EXPECT_LT(errors.back(), 0.15);
}

TEST(PatchAligner, AnotherPatchIsNoMatch) {
  const cv::Mat image = Texture(320, 240, 2);
  const cv::Mat other = Texture(320, 240, 3);
  const PatchAlignOptions options;
  int tried = 0, matched = 0;
  for (const Eigen::Vector2f& p : GridPoints(image.cols, image.rows, 29, 40)) {
    const PatchAnchor anchor = MakePatchAnchor(image, p, options);
    if (!anchor.valid) continue;
    ++tried;
    // No match (or a warp that runs off the image while it searches).
    const PatchAlignResult r = AlignPatch(anchor, other, p, options);
    if (r.status == PatchAlignStatus::kAligned) {
      ++matched;
      std::printf("matched at (%.1f, %.1f): zncc %.3f, moved %.2f px\n", p.x(), p.y(), r.zncc, (r.pixel - p).norm());
    }
  }
  ASSERT_GT(tried, 30);
  EXPECT_EQ(matched, 0);
}

TEST(PatchAligner, AShiftBeyondTheLimitIsNoMatch) {
  const cv::Mat image = Texture(320, 240, 4);
  PatchAlignOptions options;
  options.max_shift_px = 1.0;
  const Eigen::Vector2f p(160.3f, 120.6f);
  const PatchAnchor anchor = MakePatchAnchor(image, p, options);
  ASSERT_TRUE(anchor.valid);
  // Started 0.6 px off: aligned; started 1.8 px off: it converges on the
  // point, but farther from the start than allowed.
  EXPECT_EQ(AlignPatch(anchor, image, p + Eigen::Vector2f(0.6f, 0.0f), options).status,
            PatchAlignStatus::kAligned);
  const PatchAlignResult far = AlignPatch(anchor, image, p + Eigen::Vector2f(1.8f, 0.0f), options);
  EXPECT_EQ(far.status, PatchAlignStatus::kNoMatch);
  EXPECT_LT((far.pixel - p).norm(), 0.05f);
}

TEST(PatchAligner, FlatPatchesAndTheBorderHaveNoVerdict) {
  const PatchAlignOptions options;
  const cv::Mat flat(100, 100, CV_8U, cv::Scalar(128));
  EXPECT_FALSE(MakePatchAnchor(flat, Eigen::Vector2f(50.0f, 50.0f), options).valid);
  // An edge (a straight step) fixes only one direction: not an anchor.
  cv::Mat edge(100, 100, CV_8U, cv::Scalar(40));
  edge(cv::Rect(50, 0, 50, 100)).setTo(200);
  cv::GaussianBlur(edge, edge, cv::Size(0, 0), 1.5);
  EXPECT_FALSE(MakePatchAnchor(edge, Eigen::Vector2f(50.0f, 50.0f), options).valid);

  const cv::Mat image = Texture(200, 150, 5);
  // The template must fit in the image with one pixel to spare.
  EXPECT_FALSE(MakePatchAnchor(image, Eigen::Vector2f(5.0f, 70.0f), options).valid);
  const PatchAnchor anchor = MakePatchAnchor(image, Eigen::Vector2f(40.0f, 70.0f), options);
  ASSERT_TRUE(anchor.valid);
  EXPECT_EQ(AlignPatch(anchor, image, Eigen::Vector2f(4.0f, 70.0f), options).status,
            PatchAlignStatus::kOutsideImage);
  EXPECT_EQ(AlignPatch(PatchAnchor{}, image, Eigen::Vector2f(40.0f, 70.0f), options).status,
            PatchAlignStatus::kNoMatch);
}

TEST(PatchAligner, WarpBeyond) {
  EXPECT_FALSE(WarpBeyond(Eigen::Matrix2f::Identity(), 1.5));
  EXPECT_TRUE(WarpBeyond(Eigen::Matrix2f::Identity() * 1.6f, 1.5));
  EXPECT_TRUE(WarpBeyond(Eigen::Matrix2f::Identity() * 0.6f, 1.5));
  Eigen::Matrix2f rotation;
  rotation << 0.0f, -1.0f, 1.0f, 0.0f;  // a rotation keeps the patch's size
  EXPECT_FALSE(WarpBeyond(rotation, 1.5));
  Eigen::Matrix2f shear;
  shear << 1.0f, 1.0f, 0.0f, 1.0f;  // singular values 1.62 and 0.62
  EXPECT_TRUE(WarpBeyond(shear, 1.5));
}

}  // namespace
}  // namespace mcvo
