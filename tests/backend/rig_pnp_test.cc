// Generalized (multi-camera) absolute pose (include/mcvo/backend/rig_pnp.h):
// exactness without noise, accuracy with 1 px noise, outliers, fisheye
// bearings beyond 90 deg, failures, determinism, a camera without points, the
// prior hypothesis, and the KITTI-360 rig read from config/rigs.
#include "mcvo/backend/rig_pnp.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "backend/backend_test_util.h"
#include "mcvo/io/rig_io.h"

namespace mcvo {
namespace {

using test::kDeg;

constexpr double kFocal = 460.0;

Eigen::Matrix3d Ypr(double yaw, double pitch, double roll) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// cam_from_rig of a camera looking along rig +x yawed by `yaw` (rig: x
// forward, y right, z down; camera: z viewing direction, x rig right).
Rigid3d CamFromRig(double yaw, const Eigen::Vector3d& position_in_rig) {
  Eigen::Matrix3d forward_cam;
  forward_cam.col(0) = Eigen::Vector3d::UnitY();
  forward_cam.col(1) = Eigen::Vector3d::UnitZ();
  forward_cam.col(2) = Eigen::Vector3d::UnitX();
  return Rigid3d(Eigen::Matrix3d(Ypr(yaw, 0.0, 0.0) * forward_cam), position_in_rig).Inverse();
}

// Front, right, back, left; 30 deg half field of view: no overlap.
std::vector<Rigid3d> RingRig() {
  return {CamFromRig(0.0, Eigen::Vector3d(1.5, 0.0, -0.6)),
          CamFromRig(90 * kDeg, Eigen::Vector3d(0.5, 0.8, -1.0)),
          CamFromRig(180 * kDeg, Eigen::Vector3d(-0.8, 0.0, -1.0)),
          CamFromRig(-90 * kDeg, Eigen::Vector3d(0.5, -0.8, -1.0))};
}

const Rigid3d kWorldFromRig(Ypr(0.7, 0.05, -0.03), Eigen::Vector3d(20.0, -5.0, 1.0));

struct SceneSpec {
  std::vector<int> per_camera;   // correspondences per camera
  double max_angle = 30 * kDeg;  // off the optical axis
  double noise_px = 0.0;
  double outlier_fraction = 0.0;
};

struct Scene {
  std::vector<RigPnpCorrespondence> correspondences;
  std::vector<bool> is_outlier;
};

// A random unit bearing at most max_angle off +z.
Eigen::Vector3d BearingInCone(double max_angle, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double cos_angle = 1.0 - u(*rng) * (1.0 - std::cos(max_angle));  // uniform on the cap
  const double azimuth = 2.0 * M_PI * u(*rng);
  const double sin_angle = std::sqrt(std::max(0.0, 1.0 - cos_angle * cos_angle));
  return Eigen::Vector3d(sin_angle * std::cos(azimuth), sin_angle * std::sin(azimuth), cos_angle);
}

Scene MakeScene(const std::vector<Rigid3d>& cam_from_rig, const SceneSpec& spec, std::mt19937* rng) {
  Scene scene;
  std::uniform_real_distribution<double> depth(3.0, 30.0), u(0.0, 1.0);
  for (size_t c = 0; c < cam_from_rig.size(); ++c) {
    const Rigid3d world_from_cam = kWorldFromRig * cam_from_rig[c].Inverse();
    for (int k = 0; k < spec.per_camera[c]; ++k) {
      const Eigen::Vector3d bearing = BearingInCone(spec.max_angle, rng);
      RigPnpCorrespondence corr;
      corr.camera = static_cast<int>(c);
      corr.point_in_world = world_from_cam * (depth(*rng) * bearing);
      corr.bearing = test::NoisyBearing(bearing, spec.noise_px / kFocal, rng);
      const bool outlier = u(*rng) < spec.outlier_fraction;
      if (outlier) {
        // Another direction in the field of view, at least 20 px away.
        do {
          corr.bearing = BearingInCone(spec.max_angle, rng);
        } while (std::acos(std::clamp(corr.bearing.dot(bearing), -1.0, 1.0)) < std::atan(20.0 / kFocal));
      }
      scene.correspondences.push_back(corr);
      scene.is_outlier.push_back(outlier);
    }
  }
  return scene;
}

double TranslationError(const RigPnpResult& r, const Rigid3d& truth = kWorldFromRig) {
  return (r.world_from_rig.translation - truth.translation).norm();
}
double RotationError(const RigPnpResult& r, const Rigid3d& truth = kWorldFromRig) {
  return test::RotationAngle(r.world_from_rig.rotation, truth.rotation);
}

RigPnpOptions Options(double threshold_px) {
  RigPnpOptions options;
  options.threshold_px = threshold_px;
  options.focal_px = kFocal;
  return options;
}

TEST(RigPnp, NoiseFreeIsExact) {
  std::mt19937 rng(1);
  const std::vector<Rigid3d> rig = RingRig();
  const Scene scene = MakeScene(rig, {{30, 30, 30, 30}}, &rng);
  const RigPnpResult r = SolveRigPnp(rig, scene.correspondences, Options(2.0));
  ASSERT_TRUE(r.ok) << r.reason;
  std::printf("noise-free: |dt| %.3g m, |dR| %.3g rad, rms %.3g px\n", TranslationError(r), RotationError(r),
              r.rms_error_px);
  EXPECT_LT(TranslationError(r), 1e-8);
  EXPECT_LT(RotationError(r), 1e-9);
  EXPECT_EQ(r.num_inliers, 120);
  EXPECT_EQ(r.inliers_per_camera, (std::vector<int>{30, 30, 30, 30}));
  EXPECT_LT(r.rms_error_px, 1e-6);
  EXPECT_TRUE(r.reason.empty());
}

TEST(RigPnp, OnePixelNoiseIsAccurate) {
  // 4 x 50 points at 3-30 m, 1 px (at 460 px focal) isotropic noise per axis.
  // Expected: rotation ~ sigma / sqrt(N) ~ 0.01 deg, translation ~ 1 cm.
  const std::vector<Rigid3d> rig = RingRig();
  double worst_t = 0.0, worst_r = 0.0, min_rms = 1e9, max_rms = 0.0;
  int min_inliers = 1000;
  for (uint32_t seed = 10; seed < 20; ++seed) {
    std::mt19937 rng(seed);
    const Scene scene = MakeScene(rig, {{50, 50, 50, 50}, 30 * kDeg, 1.0}, &rng);
    const RigPnpResult r = SolveRigPnp(rig, scene.correspondences, Options(4.0));
    ASSERT_TRUE(r.ok) << r.reason;
    worst_t = std::max(worst_t, TranslationError(r));
    worst_r = std::max(worst_r, RotationError(r));
    min_rms = std::min(min_rms, r.rms_error_px);
    max_rms = std::max(max_rms, r.rms_error_px);
    min_inliers = std::min(min_inliers, r.num_inliers);
  }
  std::printf(
      "1 px, 10 seeds: max |dt| %.4f m, max |dR| %.4f deg, rms %.3f .. %.3f px, min inliers %d / 200\n",
      worst_t, worst_r / kDeg, min_rms, max_rms, min_inliers);
  EXPECT_LT(worst_t, 0.05);
  EXPECT_LT(worst_r, 0.05 * kDeg);
  // 2D Gaussian, sigma 1 px: rms sqrt(2) px; 4 px cuts exp(-8) of them.
  EXPECT_GT(min_rms, 1.2);
  EXPECT_LT(max_rms, 1.65);
  EXPECT_GE(min_inliers, 196);
}

TEST(RigPnp, FortyPercentOutliers) {
  const std::vector<Rigid3d> rig = RingRig();
  {
    // Noise-free inliers: exact pose, exact inlier set.
    std::mt19937 rng(2);
    const Scene scene = MakeScene(rig, {{40, 40, 40, 40}, 30 * kDeg, 0.0, 0.4}, &rng);
    const RigPnpResult r = SolveRigPnp(rig, scene.correspondences, Options(2.0));
    ASSERT_TRUE(r.ok) << r.reason;
    const int outliers = static_cast<int>(std::count(scene.is_outlier.begin(), scene.is_outlier.end(), true));
    std::printf("40 %% outliers (%d of 160), noise-free: |dt| %.3g m, inliers %d\n", outliers,
                TranslationError(r), r.num_inliers);
    EXPECT_GT(outliers, 45);
    // Exact up to Ceres' parameter tolerance (1e-8 relative, |t| = 21 m).
    EXPECT_LT(TranslationError(r), 1e-7);
    EXPECT_LT(RotationError(r), 1e-8);
    for (size_t k = 0; k < scene.is_outlier.size(); ++k) EXPECT_EQ(r.inliers[k], !scene.is_outlier[k]) << k;
  }
  double worst_t = 0.0, worst_r = 0.0;
  int false_inliers = 0, missed = 0, inliers_total = 0;
  for (uint32_t seed = 30; seed < 40; ++seed) {
    std::mt19937 rng(seed);
    const Scene scene = MakeScene(rig, {{50, 50, 50, 50}, 30 * kDeg, 1.0, 0.4}, &rng);
    const RigPnpResult r = SolveRigPnp(rig, scene.correspondences, Options(4.0));
    ASSERT_TRUE(r.ok) << r.reason;
    worst_t = std::max(worst_t, TranslationError(r));
    worst_r = std::max(worst_r, RotationError(r));
    for (size_t k = 0; k < scene.is_outlier.size(); ++k) {
      false_inliers += (r.inliers[k] && scene.is_outlier[k]) ? 1 : 0;
      missed += (!r.inliers[k] && !scene.is_outlier[k]) ? 1 : 0;
      inliers_total += scene.is_outlier[k] ? 0 : 1;
    }
  }
  std::printf(
      "40 %% outliers, 1 px, 10 seeds: max |dt| %.4f m, max |dR| %.4f deg, outliers accepted %d, "
      "inliers missed %d of %d\n",
      worst_t, worst_r / kDeg, false_inliers, missed, inliers_total);
  EXPECT_LT(worst_t, 0.06);
  EXPECT_LT(worst_r, 0.06 * kDeg);
  EXPECT_EQ(false_inliers, 0);  // outliers are >= 20 px off, the threshold 4 px
  EXPECT_LE(missed, inliers_total / 100);
}

TEST(RigPnp, FisheyeBearingsBeyond90Degrees) {
  // Two side fisheyes seeing up to 110 deg off their axis (a third of the
  // bearings behind their image plane) and one front camera.
  const std::vector<Rigid3d> rig = {CamFromRig(0.0, Eigen::Vector3d(1.5, 0.0, -0.6)),
                                    CamFromRig(90 * kDeg, Eigen::Vector3d(0.7, 0.75, -1.07)),
                                    CamFromRig(-90 * kDeg, Eigen::Vector3d(0.7, -0.15, -1.07))};
  for (double noise : {0.0, 1.0}) {
    std::mt19937 rng(3);
    Scene scene = MakeScene({rig[1], rig[2]}, {{60, 60}, 110 * kDeg, noise}, &rng);
    for (auto& c : scene.correspondences) c.camera += 1;
    const Scene front = MakeScene({rig[0]}, {{20}, 30 * kDeg, noise}, &rng);
    scene.correspondences.insert(scene.correspondences.end(), front.correspondences.begin(),
                                 front.correspondences.end());
    int behind = 0;
    for (const auto& c : scene.correspondences) behind += c.bearing.z() < 0.0 ? 1 : 0;
    const RigPnpResult r = SolveRigPnp(rig, scene.correspondences, Options(4.0));
    ASSERT_TRUE(r.ok) << r.reason;
    std::printf(
        "fisheye, %.0f px: %d of %zu bearings beyond 90 deg, |dt| %.3g m, |dR| %.3g deg, inliers %d\n", noise,
        behind, scene.correspondences.size(), TranslationError(r), RotationError(r) / kDeg, r.num_inliers);
    EXPECT_GT(behind, 25);
    if (noise == 0.0) {
      EXPECT_LT(TranslationError(r), 1e-8);
      EXPECT_EQ(r.num_inliers, 140);
    } else {
      EXPECT_LT(TranslationError(r), 0.05);
      EXPECT_LT(RotationError(r), 0.05 * kDeg);
      EXPECT_GE(r.num_inliers, 136);
    }
    // Every bearing behind 90 deg that is an inlier has a small error.
    EXPECT_LT(r.rms_error_px, noise == 0.0 ? 1e-6 : 1.7);
  }
}

TEST(RigPnp, TooFewCorrespondencesOrInliersFail) {
  std::mt19937 rng(4);
  const std::vector<Rigid3d> rig = RingRig();
  {
    const Scene scene = MakeScene(rig, {{1, 1, 1, 0}}, &rng);
    const RigPnpResult r = SolveRigPnp(rig, scene.correspondences, Options(2.0));
    EXPECT_FALSE(r.ok);
    EXPECT_NE(r.reason.find("too few correspondences"), std::string::npos) << r.reason;
    EXPECT_EQ(r.inliers.size(), 3u);
    EXPECT_EQ(r.inliers_per_camera.size(), 4u);
  }
  {
    const Scene scene = MakeScene(rig, {{3, 3, 2, 2}}, &rng);  // 10 < min_inliers 12
    const RigPnpResult r = SolveRigPnp(rig, scene.correspondences, Options(2.0));
    EXPECT_FALSE(r.ok);
    EXPECT_NE(r.reason.find("need 12"), std::string::npos) << r.reason;
  }
  {
    // Pure outliers: no pose explains 12 of them.
    const Scene scene = MakeScene(rig, {{15, 15, 15, 15}, 30 * kDeg, 0.0, 1.0}, &rng);
    const RigPnpResult r = SolveRigPnp(rig, scene.correspondences, Options(2.0));
    EXPECT_FALSE(r.ok);
    EXPECT_FALSE(r.reason.empty());
    std::printf("pure outliers: %s\n", r.reason.c_str());
  }
}

TEST(RigPnp, MinInlierIterationsIsTheSampleCountForTheNeededInliers) {
  // ceil(log(1e-4) / log(1 - (40/n)^4)): 10, 42, 356 for n = 45, 60, 100.
  EXPECT_EQ(MinInlierIterations(40, 45, 4, 0.9999), 10);
  EXPECT_EQ(MinInlierIterations(40, 60, 4, 0.9999), 42);
  EXPECT_EQ(MinInlierIterations(40, 100, 4, 0.9999), 356);
  EXPECT_EQ(MinInlierIterations(40, 40, 4, 0.9999), 1);  // every correspondence must be an inlier
  EXPECT_EQ(MinInlierIterations(40, 30, 4, 0.9999), 1);  // fewer than needed: nothing to find
  EXPECT_GT(MinInlierIterations(12, 5000, 4, 0.9999), 1000000);
  EXPECT_EQ(MinInlierIterations(12, 0, 4, 0.9999), 1);
  EXPECT_EQ(MinInlierIterations(12, 60, 4, 1.0), std::numeric_limits<int>::max());
}

TEST(RigPnp, TheSampleCapStillFindsAPoseWithTheNeededInliers) {
  // 40 inliers (1 px noise) and 20 outliers: the fewest inliers a caller
  // with min_inliers 40 accepts. The cap (42 samples at 0.9999) must find
  // the pose on every scene where the uncapped 1000 samples do (not on all
  // 100: 1 px noise can put an inlier past the 4 px threshold, 39 < 40);
  // with 30 inliers the pose is rejected either way.
  const std::vector<Rigid3d> rig = RingRig();
  int found_capped = 0, found_uncapped = 0, lost_to_cap = 0, found_30 = 0;
  double worst_t = 0.0;
  for (uint32_t seed = 100; seed < 200; ++seed) {
    for (const int inliers : {40, 30}) {
      std::mt19937 rng(seed);
      Scene scene = MakeScene(rig, {{15, 15, 15, 15}, 30 * kDeg, 1.0}, &rng);
      std::uniform_real_distribution<double> u(0.0, 1.0);
      for (int k = inliers; k < 60; ++k) {  // the last 60 - inliers become outliers
        const Eigen::Vector3d truth = scene.correspondences[static_cast<size_t>(k)].bearing;
        Eigen::Vector3d outlier;
        do {
          outlier = BearingInCone(30 * kDeg, &rng);
        } while (std::acos(std::clamp(outlier.dot(truth), -1.0, 1.0)) < std::atan(20.0 / kFocal));
        scene.correspondences[static_cast<size_t>(k)].bearing = outlier;
      }
      RigPnpOptions options = Options(4.0);
      options.min_inliers = 40;
      options.max_iterations = 1000;
      const RigPnpResult capped = SolveRigPnp(rig, scene.correspondences, options);
      options.min_inlier_confidence = 0.0;
      const RigPnpResult uncapped = SolveRigPnp(rig, scene.correspondences, options);
      if (inliers == 30) {
        found_30 += (capped.ok ? 1 : 0) + (uncapped.ok ? 1 : 0);
        continue;
      }
      found_capped += capped.ok ? 1 : 0;
      found_uncapped += uncapped.ok ? 1 : 0;
      lost_to_cap += (uncapped.ok && !capped.ok) ? 1 : 0;
      if (capped.ok) worst_t = std::max(worst_t, TranslationError(capped));
    }
  }
  std::printf("40 of 60 inliers, 100 scenes: found %d capped, %d uncapped, worst |dt| %.4f m\n", found_capped,
              found_uncapped, worst_t);
  EXPECT_GE(found_uncapped, 95);
  EXPECT_EQ(lost_to_cap, 0);
  EXPECT_LT(worst_t, 0.1);
  EXPECT_EQ(found_30, 0);
}

TEST(RigPnp, DeterministicRuns) {
  std::mt19937 rng(5);
  const std::vector<Rigid3d> rig = RingRig();
  const Scene scene = MakeScene(rig, {{50, 50, 50, 50}, 30 * kDeg, 1.0, 0.4}, &rng);
  const RigPnpResult a = SolveRigPnp(rig, scene.correspondences, Options(3.0));
  const RigPnpResult b = SolveRigPnp(rig, scene.correspondences, Options(3.0));
  ASSERT_TRUE(a.ok);
  EXPECT_EQ(a.world_from_rig.rotation.coeffs(), b.world_from_rig.rotation.coeffs());
  EXPECT_EQ(a.world_from_rig.translation, b.world_from_rig.translation);
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.rms_error_px, b.rms_error_px);
}

TEST(RigPnp, CameraWithoutCorrespondences) {
  std::mt19937 rng(6);
  const std::vector<Rigid3d> rig = RingRig();
  const Scene scene = MakeScene(rig, {{40, 30, 0, 20}, 30 * kDeg, 1.0}, &rng);
  const RigPnpResult r = SolveRigPnp(rig, scene.correspondences, Options(4.0));
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.inliers_per_camera[2], 0);
  EXPECT_GE(r.inliers_per_camera[0], 39);
  EXPECT_GE(r.inliers_per_camera[1], 29);
  EXPECT_GE(r.inliers_per_camera[3], 19);
  EXPECT_LT(TranslationError(r), 0.05);
  EXPECT_LT(RotationError(r), 0.05 * kDeg);
}

TEST(RigPnp, OneCameraOnlyCentralCase) {
  // All correspondences in one camera (the others occluded): GP3P's samples
  // are then central; 30 % outliers.
  std::mt19937 rng(77);
  const std::vector<Rigid3d> rig = RingRig();
  for (double noise : {0.0, 1.0}) {
    const Scene scene = MakeScene(rig, {{0, 0, 60, 0}, 30 * kDeg, noise, 0.3}, &rng);
    const RigPnpResult r = SolveRigPnp(rig, scene.correspondences, Options(4.0));
    ASSERT_TRUE(r.ok) << r.reason;
    std::printf("one camera, %.0f px: |dt| %.3g m, |dR| %.3g deg, inliers %d\n", noise, TranslationError(r),
                RotationError(r) / kDeg, r.num_inliers);
    EXPECT_EQ(r.inliers_per_camera, (std::vector<int>{0, 0, r.num_inliers, 0}));
    if (noise == 0.0) {
      EXPECT_LT(TranslationError(r), 1e-7);
    } else {
      EXPECT_LT(TranslationError(r), 0.05);
      EXPECT_LT(RotationError(r), 0.15 * kDeg);
    }
  }
}

TEST(RigPnp, InvalidCorrespondencesAreNeverInliers) {
  std::mt19937 rng(7);
  const std::vector<Rigid3d> rig = RingRig();
  Scene scene = MakeScene(rig, {{20, 20, 20, 20}}, &rng);
  scene.correspondences[3].bearing = Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0.0, 1.0);
  scene.correspondences[7].bearing = Eigen::Vector3d::Zero();
  scene.correspondences[11].point_in_world.x() = std::numeric_limits<double>::infinity();
  const RigPnpResult r = SolveRigPnp(rig, scene.correspondences, Options(2.0));
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_FALSE(r.inliers[3]);
  EXPECT_FALSE(r.inliers[7]);
  EXPECT_FALSE(r.inliers[11]);
  EXPECT_EQ(r.num_inliers, 77);
  EXPECT_LT(TranslationError(r), 1e-7);
}

TEST(RigPnp, PriorHypothesis) {
  const std::vector<Rigid3d> rig = RingRig();
  std::mt19937 rng(8);
  // 75 % outliers and a single RANSAC iteration: a good prior (0.22 deg,
  // 2.4 cm off) carries it, and the refinement improves on it.
  const Scene scene = MakeScene(rig, {{80, 80, 80, 80}, 30 * kDeg, 1.0, 0.75}, &rng);
  RigPnpOptions options = Options(4.0);
  options.max_iterations = 1;
  const Rigid3d prior(Eigen::Quaterniond(Ypr(0.2 * kDeg, -0.1 * kDeg, 0.0)) * kWorldFromRig.rotation,
                      kWorldFromRig.translation + Eigen::Vector3d(0.02, -0.01, 0.01));
  const RigPnpResult with_prior = SolveRigPnp(rig, scene.correspondences, options, &prior);
  ASSERT_TRUE(with_prior.ok) << with_prior.reason;
  std::printf("prior, 75 %% outliers, 1 iteration: |dt| %.4f m, |dR| %.4f deg, inliers %d\n",
              TranslationError(with_prior), RotationError(with_prior) / kDeg, with_prior.num_inliers);
  EXPECT_GE(with_prior.num_inliers, 60);
  EXPECT_LT(TranslationError(with_prior), 0.02);
  EXPECT_LT(RotationError(with_prior), 0.1 * kDeg);

  // A wrong prior does not hurt when RANSAC finds the pose.
  std::mt19937 rng2(9);
  const Scene easy = MakeScene(rig, {{40, 40, 40, 40}, 30 * kDeg, 1.0, 0.2}, &rng2);
  const Rigid3d wrong(Ypr(1.0, 0.0, 0.0), Eigen::Vector3d(0.0, 0.0, 0.0));
  const RigPnpResult with_wrong = SolveRigPnp(rig, easy.correspondences, Options(4.0), &wrong);
  ASSERT_TRUE(with_wrong.ok) << with_wrong.reason;
  EXPECT_LT(TranslationError(with_wrong), 0.05);
  EXPECT_LT(RotationError(with_wrong), 0.05 * kDeg);
}

TEST(RigPnp, Kitti360RigFromConfig) {
  // The real rig (two pinhole, two MEI fisheye cameras): bearings from
  // Camera::Unproject of random pixels, 1 px image noise, 30 % outliers.
  const Rig kitti = ReadRig(std::string(MCVO_SOURCE_DIR) + "/config/rigs/kitti360.json");
  ASSERT_EQ(kitti.NumCameras(), 4);
  std::vector<Rigid3d> cam_from_rig;
  for (const Camera& cam : kitti.cameras) cam_from_rig.push_back(cam.cam_from_rig);
  std::mt19937 rng(10);
  std::uniform_real_distribution<double> u(0.0, 1.0), depth(3.0, 40.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<RigPnpCorrespondence> correspondences;
  std::vector<bool> is_outlier;
  int behind = 0;
  for (int c = 0; c < kitti.NumCameras(); ++c) {
    const Camera& cam = kitti.cameras[static_cast<size_t>(c)];
    const Rigid3d world_from_cam = kWorldFromRig * cam.cam_from_rig.Inverse();
    int made = 0;
    while (made < 40) {
      const Eigen::Vector2d pixel(u(rng) * (cam.width - 1), u(rng) * (cam.height - 1));
      const auto bearing = cam.Unproject(pixel);
      const auto noisy = cam.Unproject(pixel + Eigen::Vector2d(noise(rng), noise(rng)));
      if (!bearing || !noisy) continue;
      RigPnpCorrespondence corr;
      corr.camera = c;
      corr.point_in_world = world_from_cam * (depth(rng) * *bearing);
      corr.bearing = *noisy;
      const bool outlier = u(rng) < 0.3;
      if (outlier) {
        const auto other =
            cam.Unproject(Eigen::Vector2d(u(rng) * (cam.width - 1), u(rng) * (cam.height - 1)));
        if (!other || std::acos(std::clamp(other->dot(*bearing), -1.0, 1.0)) < 0.05) continue;
        corr.bearing = *other;
      }
      behind += corr.bearing.z() < 0.0 ? 1 : 0;
      correspondences.push_back(corr);
      is_outlier.push_back(outlier);
      ++made;
    }
  }
  // 1 image px is at most 1 px at 460 (every focal here is above 460), so 3 px.
  const RigPnpResult r = SolveRigPnp(cam_from_rig, correspondences, Options(3.0));
  ASSERT_TRUE(r.ok) << r.reason;
  int false_inliers = 0;
  for (size_t k = 0; k < is_outlier.size(); ++k) false_inliers += (r.inliers[k] && is_outlier[k]) ? 1 : 0;
  std::printf(
      "KITTI-360 rig: %d bearings beyond 90 deg, |dt| %.4f m, |dR| %.4f deg, inliers %d (%d %d %d %d), "
      "outliers accepted %d\n",
      behind, TranslationError(r), RotationError(r) / kDeg, r.num_inliers, r.inliers_per_camera[0],
      r.inliers_per_camera[1], r.inliers_per_camera[2], r.inliers_per_camera[3], false_inliers);
  EXPECT_LT(TranslationError(r), 0.05);
  EXPECT_LT(RotationError(r), 0.05 * kDeg);
  EXPECT_EQ(false_inliers, 0);
  for (int c = 0; c < 4; ++c) EXPECT_GT(r.inliers_per_camera[static_cast<size_t>(c)], 15);
}

}  // namespace
}  // namespace mcvo
