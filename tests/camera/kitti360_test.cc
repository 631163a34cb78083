// The KITTI-360 fisheye cameras (image_02, image_03; MEI model, 1400 x 1400)
// as fixtures: agreement with cv::omnidir, round trips, and what the
// calibration says about the field of view.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <opencv2/ccalib/omnidir.hpp>
#include <opencv2/core.hpp>

#include "mcvo/camera/models.h"
#include "test_cameras.h"

namespace mcvo {
namespace {

using test::AngleBetween;
using test::Direction;
using test::DomainEdgeAngle;

constexpr double kDeg = M_PI / 180.0;

class Kitti360FisheyeTest : public ::testing::TestWithParam<Camera> {};

TEST_P(Kitti360FisheyeTest, MatchesOmnidirBeyondNinetyDegrees) {
  const Camera& camera = GetParam();
  const std::vector<double>& p = camera.params;
  std::vector<cv::Point3d> points;
  for (int it = 0; it <= 110; ++it) {
    for (int ip = 0; ip < 36; ++ip) {
      const Eigen::Vector3d d = 3.0 * Direction(it * kDeg, ip * 10.0 * kDeg);
      points.emplace_back(d.x(), d.y(), d.z());
    }
  }
  std::vector<cv::Point2d> pixels;
  const cv::Matx33d k(p[5], 0.0, p[7], 0.0, p[6], p[8], 0.0, 0.0, 1.0);
  cv::omnidir::projectPoints(points, pixels, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, p[0],
                             cv::Vec4d(p[1], p[2], p[3], p[4]));
  double worst = 0.0;
  for (size_t i = 0; i < points.size(); ++i) {
    const auto pixel = camera.Project(Eigen::Vector3d(points[i].x, points[i].y, points[i].z));
    ASSERT_TRUE(pixel);
    worst = std::max(worst, std::hypot(pixel->x() - pixels[i].x, pixel->y() - pixels[i].y));
  }
  std::printf("[ %s ] 0..110 deg vs cv::omnidir: worst %.3g px\n", camera.name.c_str(), worst);
  EXPECT_LT(worst, 1e-6);
}

// k1, k2 > 0: the distortion never folds, so the domain edge is the unified
// model's fold, cos(theta) = -1 / xi (116.9 deg for image_02, 113.1 for 03).
TEST_P(Kitti360FisheyeTest, DomainEdgeIsTheUnifiedModelFold) {
  const Camera& camera = GetParam();
  const double expected = std::acos(-1.0 / camera.params[0]);
  for (double phi : {0.0, 1.0, 2.0, 3.0, 4.0, 5.0})
    EXPECT_NEAR(DomainEdgeAngle(camera, phi), expected, 1e-12);
  EXPECT_GT(expected, 110.0 * kDeg);
}

TEST_P(Kitti360FisheyeTest, RoundTripsOverTheImage) {
  const Camera& camera = GetParam();
  double worst_pixel = 0.0, worst_angle = 0.0;
  int inside = 0;
  for (int y = 0; y < camera.height; y += 7) {
    for (int x = 0; x < camera.width; x += 7) {
      const Eigen::Vector2d pixel(x, y);
      const auto bearing = camera.Unproject(pixel);
      if (!bearing) continue;  // the corners lie beyond the fold
      ++inside;
      const auto back = camera.Project(0.7 * *bearing);
      ASSERT_TRUE(back);
      worst_pixel = std::max(worst_pixel, (*back - pixel).norm());
      const auto again = camera.Unproject(*back);
      ASSERT_TRUE(again);
      worst_angle = std::max(worst_angle, AngleBetween(*again, *bearing));
    }
  }
  std::printf("[ %s ] %d image pixels unproject; worst pixel round trip %.3g px, bearing %.3g rad\n",
              camera.name.c_str(), inside, worst_pixel, worst_angle);
  EXPECT_GT(inside, 30000);  // of 200 x 200 samples: the image circle covers most of the image
  EXPECT_LT(worst_pixel, 1e-8);
  EXPECT_LT(worst_angle, 1e-12);
}

// What the calibration gives for the field of view. At 90 degrees off axis
// the image radius is ~647 px for both cameras, inside the image in every
// direction: the whole front hemisphere is seen. At 100 degrees the radius is
// ~706 px (image_02) / ~701 px (image_03), more than the distance from the
// principal point to the nearest image edge (~683 px / ~699 px): a point 100
// degrees off axis is in the domain in every direction, but lands inside the
// 1400 x 1400 image only in 310 (image_02) / 339 (image_03) of 360 directions.
TEST_P(Kitti360FisheyeTest, FieldOfViewAt90And100Degrees) {
  const Camera& camera = GetParam();
  const Eigen::Vector2d principal(camera.params[7], camera.params[8]);
  for (const double angle_deg : {90.0, 100.0}) {
    int in_image = 0;
    double min_radius = 1e9, max_radius = 0.0;
    constexpr int kDirections = 360;
    for (int i = 0; i < kDirections; ++i) {
      const Eigen::Vector3d point = 5.0 * Direction(angle_deg * kDeg, 2.0 * M_PI * i / kDirections);
      ASSERT_TRUE(test::IsInDomain(camera, point));
      const auto pixel = camera.Project(point);
      ASSERT_TRUE(pixel);
      const double radius = (*pixel - principal).norm();
      min_radius = std::min(min_radius, radius);
      max_radius = std::max(max_radius, radius);
      in_image += camera.IsInImage(*pixel) ? 1 : 0;
    }
    std::printf("[ %s ] %.0f deg off axis: radius %.1f .. %.1f px, inside the image in %d of %d directions\n",
                camera.name.c_str(), angle_deg, min_radius, max_radius, in_image, kDirections);
    if (angle_deg == 90.0) {
      EXPECT_EQ(in_image, kDirections);
    } else {
      EXPECT_GT(min_radius, 695.0);
      EXPECT_LT(max_radius, 712.0);
      EXPECT_GT(in_image, 300);
      EXPECT_LT(in_image, kDirections);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Kitti360, Kitti360FisheyeTest,
                         ::testing::Values(test::Kitti360Image02(), test::Kitti360Image03()),
                         [](const ::testing::TestParamInfo<Camera>& param_info) {
                           return param_info.param.name;
                         });

}  // namespace
}  // namespace mcvo
