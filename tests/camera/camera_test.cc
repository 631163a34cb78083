// The run-time side of the camera module: names and aliases, parameter
// counts and checks, Camera dispatch, domain decisions named in the model
// documentation, Rig lookup.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "mcvo/camera/camera.h"
#include "mcvo/camera/models.h"
#include "test_cameras.h"

namespace mcvo {
namespace {

TEST(CameraModelNames, CanonicalNamesRoundTrip) {
  EXPECT_EQ(CameraModelName(CameraModelId::kPinhole), "pinhole");
  EXPECT_EQ(CameraModelName(CameraModelId::kRadTan), "radtan");
  EXPECT_EQ(CameraModelName(CameraModelId::kKannalaBrandt), "kannala_brandt");
  EXPECT_EQ(CameraModelName(CameraModelId::kMei), "mei");
  EXPECT_EQ(CameraModelName(CameraModelId::kDoubleSphere), "double_sphere");
  for (CameraModelId id : kAllCameraModels) EXPECT_EQ(CameraModelFromName(CameraModelName(id)), id);
}

TEST(CameraModelNames, AliasesAndUnknownNames) {
  EXPECT_EQ(CameraModelFromName("opencv"), CameraModelId::kRadTan);
  EXPECT_EQ(CameraModelFromName("equidistant"), CameraModelId::kKannalaBrandt);
  EXPECT_EQ(CameraModelFromName("fisheye"), CameraModelId::kKannalaBrandt);
  EXPECT_EQ(CameraModelFromName("omni"), CameraModelId::kMei);
  EXPECT_EQ(CameraModelFromName("unified"), CameraModelId::kMei);
  EXPECT_FALSE(CameraModelFromName(""));
  EXPECT_FALSE(CameraModelFromName("Pinhole"));  // names are case-sensitive
  EXPECT_FALSE(CameraModelFromName("ds"));
  EXPECT_FALSE(CameraModelFromName("pinhole "));
}

TEST(CameraModelNames, NumParams) {
  EXPECT_EQ(CameraModelNumParams(CameraModelId::kPinhole), 4);
  EXPECT_EQ(CameraModelNumParams(CameraModelId::kRadTan), 9);
  EXPECT_EQ(CameraModelNumParams(CameraModelId::kKannalaBrandt), 8);
  EXPECT_EQ(CameraModelNumParams(CameraModelId::kMei), 9);
  EXPECT_EQ(CameraModelNumParams(CameraModelId::kDoubleSphere), 6);
}

TEST(CameraParams, ErrorsNameTheProblem) {
  for (const Camera& camera : test::AllTestCameras()) {
    EXPECT_EQ(CameraParamsError(camera.model, camera.params), "") << camera.name;
  }
  EXPECT_EQ(CameraParamsError(CameraModelId::kRadTan, {1, 1, 0, 0, 0, 0, 0, 0}),
            "model radtan expects 9 parameters, got 8");
  EXPECT_NE(CameraParamsError(CameraModelId::kPinhole, {0, 1, 0, 0}), "");
  EXPECT_NE(CameraParamsError(CameraModelId::kPinhole, {1, 1, std::nan(""), 0}), "");
  EXPECT_NE(CameraParamsError(CameraModelId::kMei, {-0.1, 0, 0, 0, 0, 300, 300, 0, 0}), "");
  EXPECT_NE(CameraParamsError(CameraModelId::kDoubleSphere, {300, 300, 0, 0, -1.0, 0.5}), "");
  EXPECT_NE(CameraParamsError(CameraModelId::kDoubleSphere, {300, 300, 0, 0, 0.0, 1.2}), "");
}

TEST(Camera, DispatchesToTheModels) {
  for (const Camera& camera : test::AllTestCameras()) {
    const Eigen::Vector3d point(0.3, -0.2, 1.5);
    VisitCameraModel(camera.model, [&](auto m) {
      using Model = decltype(m);
      Eigen::Vector2d pixel;
      ASSERT_TRUE(Model::Project(camera.params.data(), point.data(), pixel.data()));
      EXPECT_EQ(*camera.Project(point), pixel) << camera.name;
      Eigen::Vector3d bearing;
      ASSERT_TRUE(Model::Unproject(camera.params.data(), pixel.data(), bearing.data()));
      EXPECT_EQ(*camera.Unproject(pixel), bearing) << camera.name;
    });
    EXPECT_LT((*camera.Unproject(*camera.Project(point)) - point.normalized()).norm(), 1e-12);
    Eigen::Matrix<double, 2, 3> jacobian;
    ASSERT_TRUE(camera.Project(point, &jacobian));
    EXPECT_TRUE(camera.Project(point, nullptr));
  }
}

TEST(Camera, MeanFocalLengthIsPixelsPerRadianAtTheCentre) {
  for (const Camera& camera : test::AllTestCameras()) {
    // A small angle at the principal point, along u and along v.
    const double angle = 1e-6;
    const Eigen::Vector2d centre = *camera.Project(Eigen::Vector3d(0, 0, 1));
    const double along_u = (*camera.Project(Eigen::Vector3d(std::tan(angle), 0, 1)) - centre).norm() / angle;
    const double along_v = (*camera.Project(Eigen::Vector3d(0, std::tan(angle), 1)) - centre).norm() / angle;
    EXPECT_NEAR(camera.MeanFocalLength(), 0.5 * (along_u + along_v), 1e-6 * camera.MeanFocalLength())
        << camera.name;
  }
  EXPECT_NEAR(test::Kitti360Image02().MeanFocalLength(),
              0.5 * (1336.3220825849971 + 1335.7883350012958) / 3.213404750785489, 1e-9);
}

TEST(Camera, IsInImageUsesPixelCentreConvention) {
  const Camera camera = test::MakeCamera("c", CameraModelId::kPinhole, {100, 100, 50, 40}, 100, 80);
  EXPECT_TRUE(camera.IsInImage({-0.5, -0.5}));
  EXPECT_TRUE(camera.IsInImage({99.49, 79.49}));
  EXPECT_FALSE(camera.IsInImage({99.5, 10}));
  EXPECT_FALSE(camera.IsInImage({10, 79.5}));
  EXPECT_FALSE(camera.IsInImage({-0.51, 10}));
  EXPECT_FALSE(camera.IsInImage({std::nan(""), 10}));
}

TEST(CameraDeathTest, WrongParameterCountIsAnInternalError) {
  Camera camera = test::MakeCamera("bad", CameraModelId::kMei, {1.0, 2.0}, 10, 10);
  EXPECT_DEATH(camera.Project(Eigen::Vector3d(0, 0, 1)), "parameters, expected 9");
  EXPECT_DEATH(camera.Unproject(Eigen::Vector2d(0, 0)), "parameters, expected 9");
}

TEST(CameraDomain, PinholeRejectsPointsBehindAndOnTheImagePlane) {
  const Camera camera = test::AllTestCameras()[0];
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0.1, 0.2, -1.0)));
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(1.0, 0.0, 0.0)));
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(1.0, 0.0, 1e-7)));
  EXPECT_TRUE(camera.Project(Eigen::Vector3d(1.0, 0.0, 1e-5)));
}

TEST(CameraDomain, RadTanStopsWhereTheDistortionFolds) {
  // KITTI-360 raw image_00: 1 - 1.033 s + 0.708 s^2 - 0.207 s^3 first vanishes
  // at s = r^2 ~ 2.16 (55.7 degrees); its image corners lie beyond.
  const Camera camera = test::AllTestCameras()[1];
  const double* k = camera.params.data() + 4;
  const double max_r2 = camera_internal::RadTanMaxRadiusSquared(k);
  EXPECT_NEAR(1.0 + 3 * k[0] * max_r2 + 5 * k[1] * max_r2 * max_r2 + 7 * k[4] * max_r2 * max_r2 * max_r2, 0.0,
              1e-12);
  const double r = std::sqrt(max_r2);
  EXPECT_TRUE(camera.Project(Eigen::Vector3d(r * (1 - 1e-9), 0, 1)));
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(r * (1 + 1e-9), 0, 1)));
  EXPECT_FALSE(camera.Unproject(Eigen::Vector2d(0, 0)));  // top-left corner
  EXPECT_TRUE(camera.Unproject(Eigen::Vector2d(camera.params[2], 0)));
}

TEST(CameraDomain, KannalaBrandtMaxThetaAndTheAxis) {
  // kb_fold: d theta_d / d theta = 1 - 9 * 0.01 theta^8 vanishes at theta = (1/0.09)^(1/8).
  const Camera camera = test::AllTestCameras()[4];
  const double max_theta = std::pow(1.0 / 0.09, 1.0 / 8.0);
  EXPECT_NEAR(KannalaBrandtModel::MaxTheta(camera.params.data()), max_theta, 1e-12);
  EXPECT_TRUE(camera.Project(test::Direction(max_theta - 1e-9, 1.0)));
  EXPECT_FALSE(camera.Project(test::Direction(max_theta + 1e-9, 1.0)));
  // kb_tumvi is monotonic up to 180 degrees: only the backward axis is excluded.
  const Camera tumvi = test::AllTestCameras()[3];
  EXPECT_DOUBLE_EQ(KannalaBrandtModel::MaxTheta(tumvi.params.data()), M_PI);
  EXPECT_TRUE(tumvi.Project(test::Direction(M_PI - 1e-6, 0.5)));
  EXPECT_FALSE(tumvi.Project(Eigen::Vector3d(0, 0, -1)));
}

TEST(CameraDomain, FarOutsidePixelsAreRejectedByBoundedModels) {
  const auto cameras = test::AllTestCameras();
  for (const Camera& camera : cameras) {
    const Eigen::Vector2d far(-1e6, -1e6);
    // Only these two map their domain onto the whole plane; ds_low_alpha's
    // edge (eq. 43) lies just before its denominator vanishes, so its image is
    // bounded, if by a large radius (a few thousand focal lengths).
    const bool unbounded = camera.name == "pinhole" || camera.name == "radtan_barrel_free";
    EXPECT_EQ(camera.Unproject(far).has_value(), unbounded) << camera.name;
  }
}

TEST(CameraDomain, DoubleSphereEdgeFollowsEquation43) {
  for (const Camera& camera : test::AllTestCameras()) {
    if (camera.model != CameraModelId::kDoubleSphere) continue;
    const double xi = camera.params[4], alpha = camera.params[5];
    const double w1 = alpha <= 0.5 ? alpha / (1 - alpha) : (1 - alpha) / alpha;
    const double w2 = (w1 + xi) / std::sqrt(2 * w1 * xi + xi * xi + 1);
    EXPECT_NEAR(test::DomainEdgeAngle(camera, 0.7), std::acos(-w2), 1e-12) << camera.name;
    EXPECT_GT(std::acos(-w2), 120.0 * M_PI / 180.0);
  }
}

TEST(Rig, FindCamera) {
  Rig rig;
  rig.cameras = {test::Kitti360Image02(), test::Kitti360Image03()};
  EXPECT_EQ(rig.NumCameras(), 2);
  EXPECT_EQ(rig.FindCamera("image_03"), 1);
  EXPECT_EQ(rig.FindCamera("image_02"), 0);
  EXPECT_EQ(rig.FindCamera("image_00"), -1);
}

}  // namespace
}  // namespace mcvo
