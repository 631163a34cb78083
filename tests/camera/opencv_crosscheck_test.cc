// Cross-checks of the camera models against OpenCV's implementations:
// cv::projectPoints (pinhole, radtan), cv::fisheye::projectPoints (KB),
// cv::omnidir::projectPoints (MEI, and double sphere with xi = 0, which is
// the unified model). Random points over each model's domain.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>
#include <opencv2/core.hpp>

#include "mcvo/camera/models.h"
#include "test_cameras.h"

namespace mcvo {
namespace {

using test::Direction;
using test::DomainEdgeAngle;

// Random points at most `max_angle` (and 0.99 of the domain edge) off axis.
std::vector<cv::Point3d> RandomPoints(const Camera& camera, double max_angle, int count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<cv::Point3d> points;
  for (int i = 0; i < count; ++i) {
    const double phi = 2.0 * M_PI * unit(rng);
    const double theta = std::min(max_angle, 0.99 * DomainEdgeAngle(camera, phi)) * std::sqrt(unit(rng));
    const Eigen::Vector3d p = (0.5 + 30.0 * unit(rng)) * Direction(theta, phi);
    points.emplace_back(p.x(), p.y(), p.z());
  }
  return points;
}

// Largest distance between our projections and OpenCV's, in pixels.
double MaxDifference(const Camera& camera, const std::vector<cv::Point3d>& points,
                     const std::vector<cv::Point2d>& opencv_pixels) {
  double worst = 0.0;
  for (size_t i = 0; i < points.size(); ++i) {
    const auto pixel = camera.Project(Eigen::Vector3d(points[i].x, points[i].y, points[i].z));
    EXPECT_TRUE(pixel);
    if (!pixel) continue;
    worst = std::max(worst, std::hypot(pixel->x() - opencv_pixels[i].x, pixel->y() - opencv_pixels[i].y));
  }
  return worst;
}

cv::Matx33d CameraMatrix(double fx, double fy, double cx, double cy, double skew = 0.0) {
  return cv::Matx33d(fx, skew, cx, 0.0, fy, cy, 0.0, 0.0, 1.0);
}

const cv::Vec3d kZero(0.0, 0.0, 0.0);

// Agreement bound: both sides evaluate the same closed form in double in a
// different order, so they differ by a few ulps of the pixel coordinates
// (~1e-13 px at 1e3 px); 1e-6 px leaves room for everything but a real
// difference in the model.
constexpr double kMaxPixelDifference = 1e-6;

TEST(OpenCvCrossCheck, PinholeAndRadTanMatchProjectPoints) {
  for (const Camera& camera : test::AllTestCameras()) {
    if (camera.model != CameraModelId::kPinhole && camera.model != CameraModelId::kRadTan) continue;
    const std::vector<double>& p = camera.params;
    // Up to 70 degrees off axis: beyond, the pixels of radtan_barrel_free grow
    // like tan^7 and an absolute pixel bound stops being meaningful.
    const std::vector<cv::Point3d> points = RandomPoints(camera, 70.0 * M_PI / 180.0, 2000, 3);
    cv::Mat distortion = cv::Mat::zeros(1, 5, CV_64F);
    if (camera.model == CameraModelId::kRadTan) {
      for (int i = 0; i < 5; ++i) distortion.at<double>(0, i) = p[4 + i];
    }
    std::vector<cv::Point2d> pixels;
    cv::projectPoints(points, kZero, kZero, CameraMatrix(p[0], p[1], p[2], p[3]), distortion, pixels);
    const double worst = MaxDifference(camera, points, pixels);
    std::printf("[ %s ] vs cv::projectPoints: worst %.3g px\n", camera.name.c_str(), worst);
    EXPECT_LT(worst, kMaxPixelDifference) << camera.name;
  }
}

TEST(OpenCvCrossCheck, KannalaBrandtMatchesFisheye) {
  for (const Camera& camera : test::AllTestCameras()) {
    if (camera.model != CameraModelId::kKannalaBrandt) continue;
    const std::vector<double>& p = camera.params;
    // cv::fisheye computes theta = atan(r / z): only points in front (< 90 deg).
    const std::vector<cv::Point3d> points = RandomPoints(camera, 89.0 * M_PI / 180.0, 2000, 5);
    std::vector<cv::Point2d> pixels;
    cv::fisheye::projectPoints(points, pixels, kZero, kZero, CameraMatrix(p[0], p[1], p[2], p[3]),
                               cv::Vec4d(p[4], p[5], p[6], p[7]));
    const double worst = MaxDifference(camera, points, pixels);
    std::printf("[ %s ] vs cv::fisheye::projectPoints: worst %.3g px\n", camera.name.c_str(), worst);
    EXPECT_LT(worst, kMaxPixelDifference) << camera.name;
  }
}

// omnidir's K = [gamma1 s u0; 0 gamma2 v0], D = [k1 k2 p1 p2]; our MEI is
// omnidir with s = 0.
double MeiVersusOmnidir(const Camera& camera, const std::vector<cv::Point3d>& points) {
  const std::vector<double>& p = camera.params;
  std::vector<cv::Point2d> pixels;
  cv::omnidir::projectPoints(points, pixels, kZero, kZero, CameraMatrix(p[5], p[6], p[7], p[8]), p[0],
                             cv::Vec4d(p[1], p[2], p[3], p[4]));
  return MaxDifference(camera, points, pixels);
}

TEST(OpenCvCrossCheck, MeiMatchesOmnidirOverTheWholeDomain) {
  for (const Camera& camera : test::AllTestCameras()) {
    if (camera.model != CameraModelId::kMei) continue;
    const double worst = MeiVersusOmnidir(camera, RandomPoints(camera, M_PI, 2000, 7));
    std::printf("[ %s ] vs cv::omnidir::projectPoints: worst %.3g px\n", camera.name.c_str(), worst);
    EXPECT_LT(worst, kMaxPixelDifference) << camera.name;
  }
}

// Double sphere with xi = 0: D = alpha |P| + (1 - alpha) Z, so
//   u = f X / D + c = f / (1 - alpha) * X / (Z + alpha / (1 - alpha) |P|) + c,
// the unified model = MEI with xi' = alpha / (1 - alpha), gamma = f / (1 - alpha),
// no distortion; the domains agree too (w1 = xi' or 1 / xi').
TEST(OpenCvCrossCheck, DoubleSphereWithZeroXiMatchesOmnidirUnifiedModel) {
  for (const double alpha : {0.3, 0.5, 0.59, 0.75}) {
    const Camera ds = test::MakeCamera("ds_xi0", CameraModelId::kDoubleSphere,
                                       {313.0, 314.0, 640.0, 512.0, 0.0, alpha}, 1280, 1024);
    const double xi = alpha / (1.0 - alpha);
    const Camera mei = test::MakeCamera(
        "mei_equivalent", CameraModelId::kMei,
        {xi, 0.0, 0.0, 0.0, 0.0, 313.0 / (1.0 - alpha), 314.0 / (1.0 - alpha), 640.0, 512.0}, 1280, 1024);
    const std::vector<cv::Point3d> points = RandomPoints(ds, M_PI, 2000, 9);
    const double worst = MeiVersusOmnidir(mei, points);
    std::vector<cv::Point2d> omnidir_pixels;
    cv::omnidir::projectPoints(points, omnidir_pixels, kZero, kZero,
                               CameraMatrix(mei.params[5], mei.params[6], 640.0, 512.0), xi,
                               cv::Vec4d(0, 0, 0, 0));
    const double worst_ds = MaxDifference(ds, points, omnidir_pixels);
    std::printf("[ ds alpha %.2f ] vs cv::omnidir (xi' %.4f): worst %.3g px (MEI twin %.3g px)\n", alpha, xi,
                worst_ds, worst);
    EXPECT_LT(worst_ds, kMaxPixelDifference) << alpha;
    EXPECT_LT(worst, kMaxPixelDifference) << alpha;
    // Same domain edge.
    EXPECT_NEAR(DomainEdgeAngle(ds, 0.4), DomainEdgeAngle(mei, 0.4), 1e-12) << alpha;
  }
}

}  // namespace
}  // namespace mcvo
