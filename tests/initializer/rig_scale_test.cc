// Rig scale solve (include/mcvo/initializer/rig_scale.h) on synthetic windows
// generated from a ground-truth rig trajectory with the header's conventions:
// A = rig at the anchor frame, q_i(t) = (C_i(t) - c_i) / s_i, R_i(t) = rotation of A_from_cam_i(t).
#include "mcvo/initializer/rig_scale.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr double kDeg = M_PI / 180.0;

Eigen::Matrix3d Ypr(double yaw, double pitch, double roll) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// KITTI-360 image_00 (front), image_02 (left fisheye), image_03 (right fisheye):
// rig_from_cam from config/rigs/kitti360.json (pose frame x forward, z down), rounded.
std::vector<Rigid3d> Kitti3CamRigFromCam() {
  Eigen::Matrix3d r00, r02, r03;
  r00 << 0.0377932, -0.1015790, 0.9941093, 0.9992837, 0.0019035, -0.0377954, 0.0019470, 0.9948257, 0.1015781;
  r02 << 0.9995185, 0.0041277, -0.0307525, -0.0307927, 0.0100608, -0.9994752, -0.0038161, 0.9999409,
      0.0101831;
  r03 << -0.9996822, 0.0005703, -0.0252038, -0.0252034, 0.0007821, 0.9996820, 0.0005899, 0.9999995,
      -0.0007675;
  return {Rigid3d(r00, Eigen::Vector3d(1.5752681, 0.0043914, -0.65)),
          Rigid3d(r02, Eigen::Vector3d(0.7264037, -0.1499659, -1.0686400)),
          Rigid3d(r03, Eigen::Vector3d(0.7016842, 0.7463651, -1.0751978))};
}

// Five cameras at irregular positions and orientations.
std::vector<Rigid3d> Irregular5RigFromCam() {
  return {Rigid3d(Ypr(0.0, 0.1, -1.6), Eigen::Vector3d(1.9, 0.1, -0.4)),
          Rigid3d(Ypr(1.4, -0.2, -1.5), Eigen::Vector3d(0.3, 0.9, -1.2)),
          Rigid3d(Ypr(-1.8, 0.3, -1.7), Eigen::Vector3d(-0.2, -0.7, -0.9)),
          Rigid3d(Ypr(3.0, 0.0, -1.4), Eigen::Vector3d(-1.4, 0.2, -0.6)),
          Rigid3d(Ypr(0.7, -0.6, -1.0), Eigen::Vector3d(1.1, -0.5, -1.6))};
}

// Rig driving forward at 1 m/frame (x forward, z down), yaw rising linearly by
// total_yaw over the window, a small pitch and roll oscillation.
std::vector<Rigid3d> Trajectory(int num_frames, double total_yaw) {
  std::vector<Rigid3d> world_from_rig;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  for (int t = 0; t < num_frames; ++t) {
    const double yaw = total_yaw * t / (num_frames - 1);
    const double tilt = total_yaw == 0.0 ? 0.0 : 1.0 * kDeg;
    const Eigen::Matrix3d rotation = Ypr(yaw, tilt * std::sin(0.7 * t), tilt * std::cos(0.5 * t));
    world_from_rig.emplace_back(rotation, position);
    position += rotation * Eigen::Vector3d(1.0, 0.0, 0.0);
  }
  return world_from_rig;
}

struct Noise {
  double position_m = 0.0;    // per coordinate, metric, on each camera's centre
  double rotation_rad = 0.0;  // per axis, on each camera's rotation
};

std::vector<CameraWindowTrack> MakeWindow(const std::vector<Rigid3d>& rig_from_cams,
                                          const std::vector<Rigid3d>& world_from_rig,
                                          const std::vector<double>& true_scales, int anchor,
                                          const Noise& noise, std::mt19937* rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  const Rigid3d anchor_from_world = world_from_rig[anchor].Inverse();
  std::vector<CameraWindowTrack> window;
  for (size_t c = 0; c < rig_from_cams.size(); ++c) {
    CameraWindowTrack track;
    track.cam_from_rig = rig_from_cams[c].Inverse();
    const Eigen::Vector3d centre_in_rig = rig_from_cams[c].translation;
    for (size_t t = 0; t < world_from_rig.size(); ++t) {
      const Rigid3d anchor_from_cam = anchor_from_world * world_from_rig[t] * rig_from_cams[c];
      Eigen::Vector3d displacement = anchor_from_cam.translation - centre_in_rig;
      Eigen::Matrix3d rotation = anchor_from_cam.RotationMatrix();
      if (static_cast<int>(t) != anchor) {  // the SfM anchor is exact by construction
        const Eigen::Vector3d dp(gauss(*rng), gauss(*rng), gauss(*rng));
        const Eigen::Vector3d dr(gauss(*rng), gauss(*rng), gauss(*rng));
        displacement += noise.position_m * dp;
        rotation =
            rotation * Eigen::AngleAxisd(noise.rotation_rad * dr.norm(), dr.normalized()).toRotationMatrix();
      }
      track.position_up_to_scale.push_back(displacement / true_scales[c]);
      track.rotation.push_back(rotation);
    }
    window.push_back(track);
  }
  return window;
}

double MaxRelativeError(const std::vector<double>& scales, const std::vector<double>& truth) {
  EXPECT_EQ(scales.size(), truth.size());
  double worst = 0.0;
  for (size_t c = 0; c < scales.size() && c < truth.size(); ++c) {
    worst = std::max(worst, std::abs(scales[c] / truth[c] - 1.0));
  }
  return worst;
}

const std::vector<double> kTrueScales3 = {3.7, 0.42, 12.5};
const std::vector<double> kTrueScales5 = {0.8, 5.3, 2.2, 17.0, 0.31};

TEST(RigScale, TurningKitti3CamNoiseFreeIsExactAndSolversAgree) {
  std::mt19937 rng(1);
  const auto window =
      MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 30.0 * kDeg), kTrueScales3, 3, Noise(), &rng);
  const RigScaleResult linear = SolveRigScalesLinear(window);
  ASSERT_TRUE(linear.observable) << linear.reason;
  EXPECT_LT(MaxRelativeError(linear.scales, kTrueScales3), 1e-9);
  EXPECT_LT(linear.rms_residual_m, 1e-9);
  EXPECT_EQ(linear.num_residual_blocks, 10 * 3);
  EXPECT_GT(linear.singular_value_ratio, 1e-2);

  // From the release's initial value 10, far from the truth.
  const RigScaleResult ceres = SolveRigScalesCeres(window, {10.0, 10.0, 10.0});
  ASSERT_TRUE(ceres.observable) << ceres.reason;
  for (size_t c = 0; c < 3; ++c) EXPECT_NEAR(ceres.scales[c] / linear.scales[c], 1.0, 1e-6) << c;
  std::printf("3-cam noise free: sigma ratio %.3g, linear err %.2e, ceres err %.2e\n",
              linear.singular_value_ratio, MaxRelativeError(linear.scales, kTrueScales3),
              MaxRelativeError(ceres.scales, kTrueScales3));
}

// The KITTI-360 levers are short (about 1 m) against 9 m of travel, so the
// scale is weakly conditioned (sigma ratio ~0.02 at 30 deg): relative scale
// error ~ position noise / (rotation x lever difference). With 1 mm position
// noise the worst of 20 windows stays under 1 %; 2 mm gives about 1.1 % at 20 deg.
TEST(RigScale, TurningKitti3CamNoisyWithinOnePercent) {
  std::mt19937 rng(7);
  const Noise noise{0.001, 0.01 * kDeg};
  double worst_linear = 0.0;
  double worst_ceres = 0.0;
  for (int trial = 0; trial < 20; ++trial) {
    const double yaw = (20.0 + trial) * kDeg;  // 20..39 deg over the window
    const auto window =
        MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, yaw), kTrueScales3, trial % 10, noise, &rng);
    const RigScaleResult linear = SolveRigScalesLinear(window);
    ASSERT_TRUE(linear.observable) << linear.reason;
    const RigScaleResult ceres = SolveRigScalesCeres(window, {10.0, 10.0, 10.0});
    ASSERT_TRUE(ceres.observable) << ceres.reason;
    worst_linear = std::max(worst_linear, MaxRelativeError(linear.scales, kTrueScales3));
    worst_ceres = std::max(worst_ceres, MaxRelativeError(ceres.scales, kTrueScales3));
    for (size_t c = 0; c < 3; ++c) EXPECT_NEAR(ceres.scales[c] / linear.scales[c], 1.0, 1e-6);
  }
  std::printf("3-cam, 1 mm / 0.01 deg noise, 20 windows: worst scale error linear %.3f %%, ceres %.3f %%\n",
              100.0 * worst_linear, 100.0 * worst_ceres);
  EXPECT_LT(worst_linear, 0.01);
  EXPECT_LT(worst_ceres, 0.01);
}

TEST(RigScale, PureTranslationIsNotObservable) {
  for (const double position_noise : {0.0, 0.002}) {
    std::mt19937 rng(3);
    const auto window = MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 0.0), kTrueScales3, 0,
                                   Noise{position_noise, position_noise > 0 ? 0.02 * kDeg : 0.0}, &rng);
    const RigScaleResult linear = SolveRigScalesLinear(window);
    EXPECT_FALSE(linear.observable) << "noise " << position_noise;
    EXPECT_TRUE(linear.scales.empty());
    EXPECT_NE(linear.reason.find("scale not observable"), std::string::npos) << linear.reason;
    EXPECT_LT(linear.singular_value_ratio, 1e-3);
    const RigScaleResult ceres = SolveRigScalesCeres(window, {10.0, 10.0, 10.0});
    EXPECT_FALSE(ceres.observable);
    EXPECT_TRUE(ceres.scales.empty());
    EXPECT_NE(ceres.reason.find("scale not observable"), std::string::npos) << ceres.reason;
    std::printf("pure translation, noise %.3f m: %s\n", position_noise, linear.reason.c_str());
  }
}

TEST(RigScale, TurningIrregular5CamWithinOnePercent) {
  std::mt19937 rng(11);
  const Noise noise{0.002, 0.02 * kDeg};
  double worst_linear = 0.0;
  double worst_ceres = 0.0;
  for (int trial = 0; trial < 20; ++trial) {
    const double yaw = -(20.0 + trial) * kDeg;  // turning the other way
    const auto window =
        MakeWindow(Irregular5RigFromCam(), Trajectory(10, yaw), kTrueScales5, 9 - trial % 10, noise, &rng);
    const RigScaleResult linear = SolveRigScalesLinear(window);
    ASSERT_TRUE(linear.observable) << linear.reason;
    EXPECT_EQ(linear.num_residual_blocks, 10 * 10);
    const RigScaleResult ceres = SolveRigScalesCeres(window, std::vector<double>(5, 10.0));
    ASSERT_TRUE(ceres.observable) << ceres.reason;
    worst_linear = std::max(worst_linear, MaxRelativeError(linear.scales, kTrueScales5));
    worst_ceres = std::max(worst_ceres, MaxRelativeError(ceres.scales, kTrueScales5));
  }
  std::printf("5-cam, 2 mm / 0.02 deg noise, 20 windows: worst scale error linear %.3f %%, ceres %.3f %%\n",
              100.0 * worst_linear, 100.0 * worst_ceres);
  EXPECT_LT(worst_linear, 0.01);
  EXPECT_LT(worst_ceres, 0.01);
}

TEST(RigScale, CeresIsDeterministic) {
  std::mt19937 rng(5);
  const auto window = MakeWindow(Irregular5RigFromCam(), Trajectory(10, 25.0 * kDeg), kTrueScales5, 0,
                                 Noise{0.002, 0.02 * kDeg}, &rng);
  const RigScaleResult a = SolveRigScalesCeres(window, std::vector<double>(5, 10.0));
  const RigScaleResult b = SolveRigScalesCeres(window, std::vector<double>(5, 10.0));
  ASSERT_TRUE(a.observable) << a.reason;
  EXPECT_EQ(a.scales, b.scales);  // bit-identical
}

TEST(RigScale, InconsistentInputIsRejected) {
  std::mt19937 rng(2);
  const auto good =
      MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 30.0 * kDeg), kTrueScales3, 0, Noise(), &rng);
  // Camera 1's SfM mirrored (a flipped two-view solution): its scale comes out negative.
  auto mirrored = good;
  for (auto& q : mirrored[1].position_up_to_scale) q = -q;
  const RigScaleResult linear = SolveRigScalesLinear(mirrored);
  EXPECT_FALSE(linear.observable);
  EXPECT_TRUE(linear.scales.empty());
  EXPECT_NE(linear.reason.find("not positive"), std::string::npos) << linear.reason;
  // A wrong extrinsic for camera 1 (30 cm off per axis): the least-squares
  // residual stays a few cm here, so only a tight max_rms_residual_m catches it.
  auto wrong_extrinsic = good;
  wrong_extrinsic[1].cam_from_rig.translation += Eigen::Vector3d(0.3, -0.3, 0.3);
  RigScaleOptions tight;
  tight.max_rms_residual_m = 0.01;
  const RigScaleResult rejected = SolveRigScalesLinear(wrong_extrinsic, tight);
  EXPECT_FALSE(rejected.observable);
  EXPECT_NE(rejected.reason.find("residual too large"), std::string::npos) << rejected.reason;
  const RigScaleResult ceres = SolveRigScalesCeres(wrong_extrinsic, {1.0, 1.0, 1.0}, tight);
  EXPECT_FALSE(ceres.observable);
  std::printf("wrong extrinsic: %s\n", rejected.reason.c_str());
}

TEST(RigScale, CameraThatDoesNotMoveIsReported) {
  std::mt19937 rng(2);
  auto window =
      MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 30.0 * kDeg), kTrueScales3, 0, Noise(), &rng);
  for (auto& q : window[2].position_up_to_scale) q.setZero();
  const RigScaleResult linear = SolveRigScalesLinear(window);
  EXPECT_FALSE(linear.observable);
  EXPECT_NE(linear.reason.find("camera 2 does not move"), std::string::npos) << linear.reason;
}

TEST(RigScale, NonFiniteInputIsAnExpectedFailure) {
  std::mt19937 rng(2);
  auto window =
      MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 30.0 * kDeg), kTrueScales3, 0, Noise(), &rng);
  window[1].position_up_to_scale[4].x() = std::numeric_limits<double>::quiet_NaN();
  const RigScaleResult linear = SolveRigScalesLinear(window);
  EXPECT_FALSE(linear.observable);
  EXPECT_NE(linear.reason.find("camera 1 frame 4"), std::string::npos) << linear.reason;
  EXPECT_FALSE(SolveRigScalesCeres(window, {1.0, 1.0, 1.0}).observable);
}

TEST(RigScale, BadOptionsThrowNamingTheField) {
  RigScaleOptions options;
  options.min_singular_value_ratio = -1.0;
  EXPECT_THROW(options.Check(), InputError);
  options = RigScaleOptions();
  options.max_num_iterations = 0;
  try {
    options.Check();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("max_num_iterations"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------
// Uncertainty and the combined solve with direct scale measurements.

// A measurement of camera c's scale: a length of `metres` in the world, seen
// by the SfM as metres / s_c, with a relative error `relative_error`.
ScaleMeasurement Measure(int camera, double metres, const std::vector<double>& truth, double relative_error,
                         double relative_sigma) {
  ScaleMeasurement m;
  m.camera = camera;
  m.sfm_length = metres / truth[static_cast<size_t>(camera)];
  m.metric_length = metres * (1.0 + relative_error);
  m.relative_sigma = relative_sigma;
  return m;
}

TEST(RigScale, SigmasCoverTheErrors) {
  std::mt19937 rng(21);
  const Noise noise{0.002, 0.02 * kDeg};
  double worst_z = 0.0;
  for (int trial = 0; trial < 10; ++trial) {
    const auto window = MakeWindow(Irregular5RigFromCam(), Trajectory(10, (25.0 + trial) * kDeg),
                                   kTrueScales5, 0, noise, &rng);
    const RigScaleResult linear = SolveRigScalesLinear(window);
    ASSERT_TRUE(linear.observable) << linear.reason;
    ASSERT_EQ(linear.scale_sigmas.size(), 5u);
    EXPECT_GT(linear.rig_sigma_m, 0.0005);
    EXPECT_LT(linear.rig_sigma_m, 0.01);
    for (size_t c = 0; c < 5; ++c) {
      worst_z = std::max(worst_z, std::abs(linear.scales[c] - kTrueScales5[c]) / linear.scale_sigmas[c]);
    }
  }
  // Independent noise: the sigmas are right, 50 scales stay within 4 sigma.
  std::printf("5-cam, 10 windows: worst |error| / sigma %.2f\n", worst_z);
  EXPECT_LT(worst_z, 4.0);
}

TEST(RigScale, PoorlyObservableScaleIsRefused) {
  std::mt19937 rng(4);
  // 2 deg of yaw over the window: observable by the singular value test, not precise.
  const auto window = MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 2.0 * kDeg), kTrueScales3, 0,
                                 Noise{0.002, 0.02 * kDeg}, &rng);
  RigScaleOptions options;
  options.min_singular_value_ratio = 1e-6;
  options.max_relative_scale_sigma = 0.005;  // the initializer's bound
  const RigScaleResult result = SolveRigScalesLinear(window, options);
  EXPECT_FALSE(result.observable);
  EXPECT_TRUE(result.scales.empty());
  EXPECT_NE(result.reason.find("scale poorly observable"), std::string::npos) << result.reason;
  EXPECT_GT(result.max_relative_scale_sigma, options.max_relative_scale_sigma);
  std::printf("2 deg of yaw: %s\n", result.reason.c_str());
}

TEST(RigScale, CombinedWithoutMeasurementsIsTheLinearSolve) {
  std::mt19937 rng(8);
  const auto window = MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 30.0 * kDeg), kTrueScales3, 2,
                                 Noise{0.001, 0.01 * kDeg}, &rng);
  const RigScaleResult linear = SolveRigScalesLinear(window);
  const RigScaleResult combined = SolveRigScalesCombined(window, {});
  ASSERT_TRUE(linear.observable) << linear.reason;
  ASSERT_TRUE(combined.observable) << combined.reason;
  for (size_t c = 0; c < 3; ++c) {
    EXPECT_NEAR(combined.scales[c] / linear.scales[c], 1.0, 1e-9);
    EXPECT_NEAR(combined.scale_sigmas[c] / linear.scale_sigmas[c], 1.0, 1e-6);
  }
  EXPECT_NEAR(combined.singular_value_ratio, linear.singular_value_ratio, 1e-9);
  EXPECT_NEAR(combined.rig_sigma_m / linear.rig_sigma_m, 1.0, 1e-6);
  EXPECT_EQ(combined.num_measurements, 0);
}

// Pure translation: the rig rows give only the ratios of the scales; a
// measurement of one camera's scale fixes all three.
TEST(RigScale, MeasurementsFixThePureTranslationScale) {
  std::mt19937 rng(3);
  for (const double noise : {0.0, 0.001}) {
    const auto window = MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 0.0), kTrueScales3, 0,
                                   Noise{noise, noise > 0 ? 0.01 * kDeg : 0.0}, &rng);
    EXPECT_FALSE(SolveRigScalesLinear(window).observable);
    std::vector<ScaleMeasurement> measurements;
    for (int k = 0; k < 40; ++k) {
      const double error = noise > 0 ? 0.02 * std::sin(1.7 * k) : 0.0;  // +-2 %, zero mean
      measurements.push_back(Measure(0, 5.0 + k, kTrueScales3, error, 0.02));
    }
    const RigScaleResult result = SolveRigScalesCombined(window, measurements);
    ASSERT_TRUE(result.observable) << result.reason;
    EXPECT_EQ(result.num_measurements, 40);
    std::printf(
        "pure translation + 40 measurements of camera 0, noise %.3f: worst scale error %.3f %%, "
        "sigma ratio %.3g, measurement sigma factor %.3g\n",
        noise, 100.0 * MaxRelativeError(result.scales, kTrueScales3), result.singular_value_ratio,
        result.measurement_sigma_factor);
    EXPECT_LT(MaxRelativeError(result.scales, kTrueScales3), noise > 0 ? 0.01 : 1e-9);
  }
}

// One camera and measurements only (a monocular window with a known length).
TEST(RigScale, OneCameraWithMeasurements) {
  std::mt19937 rng(3);
  auto window = MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 0.0), kTrueScales3, 0, Noise(), &rng);
  window.resize(1);
  const RigScaleResult alone = SolveRigScalesCombined(window, {});
  EXPECT_FALSE(alone.observable);
  EXPECT_NE(alone.reason.find("not observable"), std::string::npos) << alone.reason;
  const RigScaleResult measured = SolveRigScalesCombined(
      window, {Measure(0, 7.0, kTrueScales3, 0.0, 0.01), Measure(0, 9.0, kTrueScales3, 0.0, 0.01)});
  ASSERT_TRUE(measured.observable) << measured.reason;
  EXPECT_NEAR(measured.scales[0], kTrueScales3[0], 1e-9);
}

TEST(RigScale, BadMeasurementsAreExpectedFailures) {
  std::mt19937 rng(2);
  const auto window =
      MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 30.0 * kDeg), kTrueScales3, 0, Noise(), &rng);
  ScaleMeasurement bad = Measure(1, 5.0, kTrueScales3, 0.0, 0.01);
  bad.metric_length = std::numeric_limits<double>::quiet_NaN();
  const RigScaleResult result = SolveRigScalesCombined(window, {bad});
  EXPECT_FALSE(result.observable);
  EXPECT_NE(result.reason.find("measurement 0 (camera 1)"), std::string::npos) << result.reason;
}

TEST(RigScaleDeathTest, MalformedMeasurementAborts) {
  std::mt19937 rng(2);
  const auto window =
      MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 30.0 * kDeg), kTrueScales3, 0, Noise(), &rng);
  EXPECT_DEATH(SolveRigScalesCombined(
                   window, {Measure(0, 5.0, kTrueScales3, 0.0, 0.01), ScaleMeasurement{3, 1, 1, 0.1}}),
               "measurement 1 names camera 3 of 3");
  EXPECT_DEATH(SolveRigScalesCombined(window, {ScaleMeasurement{0, 1, 1, 0.0}}),
               "relative_sigma must be > 0");
  EXPECT_DEATH(SolveRigScalesCombined({}, {}), "at least 1 camera");
}

// A malformed window is a programmer error (the initializer assembles it): MCVO_CHECK.
TEST(RigScaleDeathTest, MalformedWindowAborts) {
  std::mt19937 rng(2);
  const auto window =
      MakeWindow(Kitti3CamRigFromCam(), Trajectory(10, 30.0 * kDeg), kTrueScales3, 0, Noise(), &rng);
  EXPECT_DEATH(SolveRigScalesLinear({window[0]}), "at least 2 cameras");
  auto one_frame = window;
  for (auto& cam : one_frame) {
    cam.position_up_to_scale.resize(1);
    cam.rotation.resize(1);
  }
  EXPECT_DEATH(SolveRigScalesLinear(one_frame), "at least 2 frames");
  auto mismatched = window;
  mismatched[2].position_up_to_scale.pop_back();
  EXPECT_DEATH(SolveRigScalesLinear(mismatched), "camera 2 has 9 positions");
  auto missing_rotation = window;
  missing_rotation[1].rotation.pop_back();
  EXPECT_DEATH(SolveRigScalesCeres(missing_rotation, {1.0, 1.0, 1.0}), "camera 1 has 9 rotations");
  EXPECT_DEATH(SolveRigScalesCeres(window, {1.0, 1.0}), "2 initial scales for 3 cameras");
  EXPECT_DEATH(SolveRigScalesCeres(window, {1.0, -1.0, 1.0}), "initial scale must be > 0");
}

}  // namespace
}  // namespace mcvo
