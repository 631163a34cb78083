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
