// Monocular window SfM (include/mcvo/initializer/camera_sfm.h) on synthetic
// tracks (synthetic_rig_tracks.h): poses and points are compared with the
// ground truth after fixing its scale the SfM's way (|centre of r| = 1).
#include "mcvo/initializer/camera_sfm.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "initializer/synthetic_rig_tracks.h"

namespace mcvo {
namespace {

using testing::CamAnchorFromCam;
using testing::CameraWindowObservations;
using testing::kSynthDeg;
using testing::LandmarkOptions;
using testing::LandmarksAroundPath;
using testing::LoadPresetRig;
using testing::MakeRigTracks;
using testing::SyntheticRigTracks;
using testing::TrackOptions;
using testing::TurningTrajectory;

constexpr double kRadToDeg = 180.0 / M_PI;

double RotationErrorDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return kRadToDeg * a.angularDistance(b);
}

struct SfmErrors {
  double max_rotation_deg = 0.0;
  double max_position = 0.0;  // relative to |centre of r| (= 1 in the SfM)
  double median_point = 0.0;  // relative error of the points, median
  double p90_point = 0.0;
  int num_points = 0;
};

// Errors of an SfM of camera `camera` over frames [begin, end) against the truth.
SfmErrors Compare(const SyntheticRigTracks& tracks, const Rig& rig, int camera, int begin, int anchor,
                  int reference, const CameraSfmResult& result) {
  const Camera& cam = rig.cameras[static_cast<size_t>(camera)];
  const double truth_scale =
      CamAnchorFromCam(tracks, cam, begin + anchor, begin + reference).translation.norm();
  SfmErrors errors;
  for (size_t k = 0; k < result.anchor_from_cam.size(); ++k) {
    const Rigid3d truth = CamAnchorFromCam(tracks, cam, begin + anchor, begin + static_cast<int>(k));
    errors.max_rotation_deg = std::max(errors.max_rotation_deg,
                                       RotationErrorDeg(truth.rotation, result.anchor_from_cam[k].rotation));
    errors.max_position =
        std::max(errors.max_position,
                 (truth.translation / truth_scale - result.anchor_from_cam[k].translation).norm());
  }
  const Rigid3d anchor_cam_from_world =
      cam.cam_from_rig * tracks.world_from_rig[static_cast<size_t>(begin + anchor)].Inverse();
  std::vector<double> point_errors;
  for (const auto& [id, point] : result.points) {
    const Eigen::Vector3d truth = anchor_cam_from_world *
                                  tracks.landmarks[static_cast<size_t>(tracks.features.at(id).landmark)] /
                                  truth_scale;
    point_errors.push_back((point - truth).norm() / truth.norm());
  }
  std::sort(point_errors.begin(), point_errors.end());
  errors.num_points = static_cast<int>(point_errors.size());
  if (!point_errors.empty()) {
    errors.median_point = point_errors[point_errors.size() / 2];
    errors.p90_point = point_errors[point_errors.size() * 9 / 10];
  }
  return errors;
}

SyntheticRigTracks TurningTracks(const Rig& rig, double noise_px, uint64_t seed, int frames = 10,
                                 double step_m = 0.6, double deg_per_frame = 3.0) {
  LandmarkOptions landmark_options;
  landmark_options.seed = seed;
  const auto world_from_rig = TurningTrajectory(frames, step_m, deg_per_frame);
  TrackOptions options;
  options.seed = seed;
  options.pixel_noise_px = noise_px;
  options.cross_camera = false;
  return MakeRigTracks(rig, world_from_rig, LandmarksAroundPath(world_from_rig, landmark_options), options);
}

TEST(CameraSfm, NoiseFreeRecoversPosesAndPointsUpToScale) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  const SyntheticRigTracks tracks = TurningTracks(rig, 0.0, 1);
  for (int camera = 0; camera < rig.NumCameras(); ++camera) {
    const auto observations = CameraWindowObservations(tracks, camera, 0, 10);
    const CameraSfmResult result = SolveCameraWindowSfm(10, 0, 9, observations);
    ASSERT_TRUE(result.ok) << rig.cameras[camera].name << ": " << result.reason;
    EXPECT_TRUE(result.reason.empty());
    ASSERT_EQ(result.anchor_from_cam.size(), 10u);
    EXPECT_NEAR(result.anchor_from_cam[9].translation.norm(), 1.0, 1e-12);
    EXPECT_EQ(result.anchor_from_cam[0].translation, Eigen::Vector3d::Zero());
    EXPECT_EQ(result.anchor_from_cam[0].rotation.coeffs(), Eigen::Quaterniond::Identity().coeffs());
    const SfmErrors e = Compare(tracks, rig, camera, 0, 0, 9, result);
    std::printf(
        "%s noise free: %d inliers, %d points, rms %.2e px, parallax %.1f deg, rot err %.2e deg, "
        "pos err %.2e, point err p90 %.2e\n",
        rig.cameras[camera].name.c_str(), result.num_inliers, e.num_points, result.rms_reprojection_px,
        result.mean_parallax_deg, e.max_rotation_deg, e.max_position, e.p90_point);
    EXPECT_LT(e.max_rotation_deg, 1e-6);
    EXPECT_LT(e.max_position, 1e-6);
    EXPECT_LT(e.p90_point, 1e-6);
    EXPECT_GT(e.num_points, 100);
    EXPECT_GT(result.num_inliers, 80);
    EXPECT_LT(result.rms_reprojection_px, 1e-6);
    EXPECT_GT(result.mean_parallax_deg, 2.0);
  }
}

// The anchor need not be the first frame, nor the reference the last: frames
// on both sides of the anchor are posed (nearest first).
TEST(CameraSfm, AnchorInsideTheWindow) {
  const Rig rig = LoadPresetRig("irregular5");
  const SyntheticRigTracks tracks = TurningTracks(rig, 0.0, 4);
  const auto observations = CameraWindowObservations(tracks, 0, 0, 10);
  const CameraSfmResult result = SolveCameraWindowSfm(10, 3, 8, observations);
  ASSERT_TRUE(result.ok) << result.reason;
  const SfmErrors e = Compare(tracks, rig, 0, 0, 3, 8, result);
  EXPECT_LT(e.max_rotation_deg, 1e-6);
  EXPECT_LT(e.max_position, 1e-6);
  EXPECT_EQ(result.anchor_from_cam[3].translation, Eigen::Vector3d::Zero());
  EXPECT_NEAR(result.anchor_from_cam[8].translation.norm(), 1.0, 1e-12);
}

// 1 px of pixel noise on every camera of two rigs (pinhole, radtan, MEI,
// Kannala-Brandt, double sphere), 3 seeds each. Measured worst cases
// (150 features, 10 frames, 3 deg and 0.6 m per frame): rotation 0.40 deg,
// position 2.4 % of |c_r|, median point error 3.2 %, rms 0.89-1.81 px; the
// bounds are about twice that.
TEST(CameraSfm, NoisyAccuracyOnEveryCameraModel) {
  for (const char* name : {"kitti360_3cam", "irregular5"}) {
    const Rig rig = LoadPresetRig(name);
    for (uint64_t seed = 1; seed <= 3; ++seed) {
      const SyntheticRigTracks tracks = TurningTracks(rig, 1.0, seed);
      for (int camera = 0; camera < rig.NumCameras(); ++camera) {
        const CameraSfmResult result =
            SolveCameraWindowSfm(10, 0, 9, CameraWindowObservations(tracks, camera, 0, 10));
        ASSERT_TRUE(result.ok) << name << " " << rig.cameras[camera].name << " seed " << seed << ": "
                               << result.reason;
        const SfmErrors e = Compare(tracks, rig, camera, 0, 0, 9, result);
        std::printf(
            "%-20s seed %d: %3d inliers, %3d points, rms %.2f px, rot %.3f deg, pos %.4f, point median "
            "%.4f\n",
            rig.cameras[camera].name.c_str(), static_cast<int>(seed), result.num_inliers, e.num_points,
            result.rms_reprojection_px, e.max_rotation_deg, e.max_position, e.median_point);
        EXPECT_LT(e.max_rotation_deg, 0.7) << rig.cameras[camera].name;
        EXPECT_LT(e.max_position, 0.045) << rig.cameras[camera].name;
        EXPECT_LT(e.median_point, 0.065) << rig.cameras[camera].name;
        EXPECT_GT(result.rms_reprojection_px, 0.3);
        EXPECT_LT(result.rms_reprojection_px, 3.0);
        EXPECT_GT(e.num_points, 80);
      }
    }
  }
}

// KITTI-360's side fisheyes (MEI, 1400 x 1400) see beyond 90 degrees from
// their axis: bearings with z < 0 are used like any other.
TEST(CameraSfm, FisheyeBeyondNinetyDegrees) {
  const Rig rig = LoadPresetRig("kitti360");
  const int camera = rig.FindCamera("image_02");
  ASSERT_GE(camera, 0);
  const SyntheticRigTracks tracks = TurningTracks(rig, 0.0, 2);
  const auto observations = CameraWindowObservations(tracks, camera, 0, 10);
  const CameraSfmResult result = SolveCameraWindowSfm(10, 0, 9, observations);
  ASSERT_TRUE(result.ok) << result.reason;
  int behind = 0;
  for (const WindowObservation& obs : observations) {
    if (obs.frame == 0 && obs.bearing.z() < 0.0 && result.points.count(obs.id) != 0) ++behind;
  }
  std::printf("image_02: %d triangulated points seen at more than 90 deg from the axis\n", behind);
  EXPECT_GE(behind, 5);
  const SfmErrors e = Compare(tracks, rig, camera, 0, 0, 9, result);
  EXPECT_LT(e.max_rotation_deg, 1e-6);
  EXPECT_LT(e.max_position, 1e-6);
  EXPECT_LT(e.p90_point, 1e-6);
}

// Tracks drifting by 10 px (10 % of them) are rejected by the RANSACs and
// the reprojection threshold; the rest gives the noisy-case accuracy.
TEST(CameraSfm, OutlierTracksAreRejected) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  LandmarkOptions landmark_options;
  const auto world_from_rig = TurningTrajectory(10, 0.6, 3.0);
  TrackOptions options;
  options.pixel_noise_px = 0.5;
  options.outlier_fraction = 0.1;
  options.cross_camera = false;
  const SyntheticRigTracks tracks =
      MakeRigTracks(rig, world_from_rig, LandmarksAroundPath(world_from_rig, landmark_options), options);
  for (int camera = 0; camera < rig.NumCameras(); ++camera) {
    const CameraSfmResult result =
        SolveCameraWindowSfm(10, 0, 9, CameraWindowObservations(tracks, camera, 0, 10));
    ASSERT_TRUE(result.ok) << result.reason;
    int outliers = 0;
    for (const auto& [id, point] : result.points) outliers += tracks.features.at(id).outlier ? 1 : 0;
    const SfmErrors e = Compare(tracks, rig, camera, 0, 0, 9, result);
    std::printf(
        "%s with 10 %% outlier tracks: %d of %zu points from outlier tracks, rot %.3f deg, pos %.4f\n",
        rig.cameras[camera].name.c_str(), outliers, result.points.size(), e.max_rotation_deg, e.max_position);
    EXPECT_LE(outliers, static_cast<int>(result.points.size()) / 50);
    EXPECT_LT(e.max_rotation_deg, 0.3);
    EXPECT_LT(e.max_position, 0.02);
  }
}

TEST(CameraSfm, TooFewCorrespondences) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  LandmarkOptions landmark_options;
  const auto world_from_rig = TurningTrajectory(10, 0.6, 3.0);
  TrackOptions options;
  options.max_features_per_camera = 15;
  const SyntheticRigTracks tracks =
      MakeRigTracks(rig, world_from_rig, LandmarksAroundPath(world_from_rig, landmark_options), options);
  const CameraSfmResult result = SolveCameraWindowSfm(10, 0, 9, CameraWindowObservations(tracks, 0, 0, 10));
  EXPECT_FALSE(result.ok);
  EXPECT_TRUE(result.anchor_from_cam.empty());
  EXPECT_TRUE(result.points.empty());
  EXPECT_NE(result.reason.find("too few correspondences between frames 0 and 9"), std::string::npos)
      << result.reason;
  std::printf("%s\n", result.reason.c_str());
}

// A camera turning about its own centre: the bearings move, but there is no
// baseline. (A rig turning on the spot is not this: its cameras sit off the
// rig origin and translate.)
TEST(CameraSfm, PureRotationHasTooLittleParallax) {
  Rig rig = LoadPresetRig("kitti360_3cam");
  for (Camera& camera : rig.cameras) camera.cam_from_rig.translation.setZero();  // centres at the rig origin
  LandmarkOptions landmark_options;
  const auto world_from_rig = TurningTrajectory(10, 0.0, 2.0);
  TrackOptions options;
  options.pixel_noise_px = 0.5;
  const SyntheticRigTracks tracks =
      MakeRigTracks(rig, world_from_rig,
                    LandmarksAroundPath(testing::StraightTrajectory(2, 1.0), landmark_options), options);
  for (int camera = 0; camera < rig.NumCameras(); ++camera) {
    const CameraSfmResult result =
        SolveCameraWindowSfm(10, 0, 9, CameraWindowObservations(tracks, camera, 0, 10));
    EXPECT_FALSE(result.ok);
    EXPECT_NE(result.reason.find("parallax"), std::string::npos) << result.reason;
    std::printf("%s: %s\n", rig.cameras[camera].name.c_str(), result.reason.c_str());
  }
}

TEST(CameraSfm, FrameThatCannotBePosed) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  const SyntheticRigTracks tracks = TurningTracks(rig, 0.0, 3);
  std::vector<WindowObservation> observations;
  int kept_in_frame_4 = 0;
  for (const WindowObservation& obs : CameraWindowObservations(tracks, 0, 0, 10)) {
    if (obs.frame == 4 && kept_in_frame_4++ >= 6) continue;  // frame 4 keeps 6 observations
    observations.push_back(obs);
  }
  const CameraSfmResult result = SolveCameraWindowSfm(10, 0, 9, observations);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.reason.find("frame 4 cannot be posed"), std::string::npos) << result.reason;
  std::printf("%s\n", result.reason.c_str());
}

// Same input, same output, bit for bit; the order of the observations does not matter.
TEST(CameraSfm, DeterministicAndOrderIndependent) {
  const Rig rig = LoadPresetRig("irregular5");
  const SyntheticRigTracks tracks = TurningTracks(rig, 1.0, 5);
  std::vector<WindowObservation> observations = CameraWindowObservations(tracks, 1, 0, 10);
  const CameraSfmResult a = SolveCameraWindowSfm(10, 0, 9, observations);
  const CameraSfmResult b = SolveCameraWindowSfm(10, 0, 9, observations);
  std::reverse(observations.begin(), observations.end());
  std::rotate(observations.begin(), observations.begin() + 37, observations.end());
  const CameraSfmResult c = SolveCameraWindowSfm(10, 0, 9, observations);
  ASSERT_TRUE(a.ok) << a.reason;
  for (const CameraSfmResult* other : {&b, &c}) {
    ASSERT_TRUE(other->ok);
    ASSERT_EQ(other->anchor_from_cam.size(), a.anchor_from_cam.size());
    for (size_t k = 0; k < a.anchor_from_cam.size(); ++k) {
      EXPECT_EQ(other->anchor_from_cam[k].rotation.coeffs(), a.anchor_from_cam[k].rotation.coeffs());
      EXPECT_EQ(other->anchor_from_cam[k].translation, a.anchor_from_cam[k].translation);
    }
    EXPECT_EQ(other->points, a.points);
    EXPECT_EQ(other->rms_reprojection_px, a.rms_reprojection_px);
    EXPECT_EQ(other->num_inliers, a.num_inliers);
  }
}

TEST(CameraSfmDeathTest, BadWindowAborts) {
  EXPECT_DEATH(SolveCameraWindowSfm(10, 5, 5, {}), "anchor");
  EXPECT_DEATH(SolveCameraWindowSfm(10, 0, 10, {}), "reference");
  WindowObservation obs;
  obs.frame = 12;
  EXPECT_DEATH(SolveCameraWindowSfm(10, 0, 9, {obs}), "in frame 12, window has 10 frames");
  WindowObservation twice;
  EXPECT_DEATH(SolveCameraWindowSfm(10, 0, 9, {twice, twice}), "observed twice in frame 0");
}

}  // namespace
}  // namespace mcvo
