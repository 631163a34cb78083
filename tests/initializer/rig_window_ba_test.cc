// Rig window bundle adjustment (include/mcvo/initializer/rig_window_ba.h) on
// synthetic tracks: started from the truth with a wrong scale and perturbed
// poses and points, it must find the metric scale wherever the data hold it.
#include "mcvo/initializer/rig_window_ba.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <vector>

#include <gtest/gtest.h>

#include "initializer/synthetic_rig_tracks.h"

namespace mcvo {
namespace {

using testing::AnchorFromRig;
using testing::LandmarkOptions;
using testing::LandmarksAroundPath;
using testing::LoadPresetRig;
using testing::MakeRigTracks;
using testing::StraightTrajectory;
using testing::SyntheticRigTracks;
using testing::TrackOptions;
using testing::TurningTrajectory;

struct Problem {
  std::vector<Rigid3d> cam_from_rig;
  std::vector<Rigid3d> world_from_rig;         // initial: truth scaled by `scale`, perturbed
  std::map<uint64_t, Eigen::Vector3d> points;  // initial
  std::vector<RigWindowObservation> observations;
};

// Window = the first `frames` frames; world = rig at frame 0. Initial values:
// the truth scaled by `scale`, positions and points moved by up to 2 cm.
Problem MakeProblem(const Rig& rig, const SyntheticRigTracks& tracks, int frames, double scale) {
  Problem p;
  for (const Camera& camera : rig.cameras) p.cam_from_rig.push_back(camera.cam_from_rig);
  for (int t = 0; t < frames; ++t) {
    Rigid3d pose = AnchorFromRig(tracks, 0, t);
    const Eigen::Vector3d offset =
        t == 0 ? Eigen::Vector3d::Zero()
               : Eigen::Vector3d(0.02 * Eigen::Vector3d(std::sin(t), std::cos(2 * t), 0.5));
    pose.translation = scale * pose.translation + offset;
    p.world_from_rig.push_back(pose);
    const RigFrameObservations& frame = tracks.frames[static_cast<size_t>(t)];
    for (int c = 0; c < rig.NumCameras(); ++c) {
      for (const FeatureObservation& f : frame.cameras[static_cast<size_t>(c)]) {
        p.observations.push_back({t, c, f.id, f.bearing});
      }
    }
    for (const CrossCameraObservation& x : frame.cross_camera) {
      p.observations.push_back({t, x.camera_b, x.id, x.bearing_b});
    }
  }
  const Rigid3d anchor_from_world = tracks.world_from_rig[0].Inverse();
  for (const auto& obs : p.observations) {
    if (p.points.count(obs.landmark) != 0) continue;
    const Eigen::Vector3d truth =
        anchor_from_world * tracks.landmarks[static_cast<size_t>(tracks.features.at(obs.landmark).landmark)];
    const double h = static_cast<double>(obs.landmark % 17) - 8.0;
    p.points.emplace(obs.landmark, scale * truth + 0.0025 * Eigen::Vector3d(h, -h, 0.5 * h));
  }
  return p;
}

SyntheticRigTracks Tracks(const Rig& rig, const std::vector<Rigid3d>& world_from_rig, double noise,
                          bool cross) {
  TrackOptions options;
  options.pixel_noise_px = noise;
  options.cross_camera = cross;
  return MakeRigTracks(rig, world_from_rig, LandmarksAroundPath(world_from_rig, LandmarkOptions()), options);
}

double TravelError(const RigWindowBaResult& result, const SyntheticRigTracks& tracks) {
  const int last = static_cast<int>(result.world_from_rig.size()) - 1;
  return result.travel_m / AnchorFromRig(tracks, 0, last).translation.norm() - 1.0;
}

// Noise free, 5 % off in scale: the rotated lever arms bring the truth back.
TEST(RigWindowBa, NoiseFreeTurnRecoversTheMetricScale) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  const SyntheticRigTracks tracks = Tracks(rig, TurningTrajectory(10, 0.6, 3.0), 0.0, false);
  const Problem p = MakeProblem(rig, tracks, 10, 1.05);
  RigWindowBaOptions options;
  options.max_iterations = 100;
  const RigWindowBaResult result =
      AdjustRigWindow(p.cam_from_rig, 0, p.world_from_rig, p.points, p.observations, options);
  ASSERT_TRUE(result.ok) << result.reason;
  std::printf("noise free: %d observations, rms %.2e px, travel error %.2e, sigma %.2e\n",
              result.num_observations, result.rms_reprojection_px, TravelError(result, tracks),
              result.travel_relative_sigma);
  EXPECT_LT(std::abs(TravelError(result, tracks)), 1e-6);
  for (size_t t = 0; t < result.world_from_rig.size(); ++t) {
    const Rigid3d truth = AnchorFromRig(tracks, 0, static_cast<int>(t));
    EXPECT_LT((result.world_from_rig[t].translation - truth.translation).norm(), 1e-6) << t;
    EXPECT_LT(result.world_from_rig[t].rotation.angularDistance(truth.rotation), 1e-8) << t;
  }
  EXPECT_EQ(result.world_from_rig[0].translation, Eigen::Vector3d::Zero());  // the fixed frame
  EXPECT_LT(result.travel_relative_sigma, 1e-6);
  EXPECT_LT(result.rms_reprojection_px, 1e-6);
  EXPECT_GT(result.points.size(), 300u);
}

// With noise, the reported sigma is what separates a usable scale from an
// unusable one: a straight drive without overlap has none; with the stereo
// pair's cross-camera observations it is well below 1 %.
TEST(RigWindowBa, ScaleSigmaReflectsObservability) {
  const Rig stereo = LoadPresetRig("kitti360_stereo");
  for (const bool cross : {false, true}) {
    const SyntheticRigTracks tracks = Tracks(stereo, StraightTrajectory(10, 0.8), 1.0, cross);
    const Problem p = MakeProblem(stereo, tracks, 10, 1.0);
    const RigWindowBaResult result =
        AdjustRigWindow(p.cam_from_rig, 0, p.world_from_rig, p.points, p.observations);
    ASSERT_TRUE(result.ok) << result.reason;
    std::printf("stereo straight, 1 px, cross %d: travel error %.3f %%, sigma %.3f %%\n", cross,
                100 * TravelError(result, tracks), 100 * result.travel_relative_sigma);
    if (cross) {
      EXPECT_LT(result.travel_relative_sigma, 0.005);
      EXPECT_LT(std::abs(TravelError(result, tracks)), 0.01);
    } else {
      EXPECT_GT(result.travel_relative_sigma, 0.05);
    }
  }
}

// Pixels per camera: a fisheye's residuals in its own (fewer) pixels per radian.
TEST(RigWindowBa, PerCameraFocalsAreUsed) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  const SyntheticRigTracks tracks = Tracks(rig, TurningTrajectory(10, 0.6, 3.0), 1.0, false);
  const Problem p = MakeProblem(rig, tracks, 10, 1.0);
  RigWindowBaOptions options;
  const RigWindowBaResult virtual_focal =
      AdjustRigWindow(p.cam_from_rig, 0, p.world_from_rig, p.points, p.observations, options);
  for (const Camera& camera : rig.cameras) options.camera_focal_px.push_back(camera.MeanFocalLength());
  const RigWindowBaResult own_focal =
      AdjustRigWindow(p.cam_from_rig, 0, p.world_from_rig, p.points, p.observations, options);
  ASSERT_TRUE(virtual_focal.ok && own_focal.ok);
  // 1 px of noise per axis: the rms of the 2-D error is near sqrt(2) px in each camera's own pixels.
  std::printf("rms at the virtual focal %.3f px, in each camera's pixels %.3f px\n",
              virtual_focal.rms_reprojection_px, own_focal.rms_reprojection_px);
  EXPECT_GT(own_focal.rms_reprojection_px, 1.1);
  EXPECT_LT(own_focal.rms_reprojection_px, 1.6);
}

TEST(RigWindowBaDeathTest, BadInputAborts) {
  const std::vector<Rigid3d> cam_from_rig(2);
  const std::vector<Rigid3d> poses(3);
  EXPECT_DEATH(AdjustRigWindow(cam_from_rig, 3, poses, {}, {}), "fixed frame 3 of 3");
  EXPECT_DEATH(AdjustRigWindow(cam_from_rig, 0, poses, {}, {{5, 0, 1, Eigen::Vector3d::UnitZ()}}),
               "observation in frame 5 of 3");
  EXPECT_DEATH(AdjustRigWindow(cam_from_rig, 0, poses, {}, {{0, 2, 1, Eigen::Vector3d::UnitZ()}}),
               "observation by camera 2 of 2");
  RigWindowBaOptions options;
  options.camera_focal_px = {400.0};
  EXPECT_DEATH(AdjustRigWindow(cam_from_rig, 0, poses, {}, {}, options), "1 camera focals for 2 cameras");
}

TEST(RigWindowBa, TooFewObservationsIsAnExpectedFailure) {
  const RigWindowBaResult result =
      AdjustRigWindow(std::vector<Rigid3d>(1), 0, std::vector<Rigid3d>(2), {}, {});
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.reason.find("0 usable observations"), std::string::npos) << result.reason;
}

}  // namespace
}  // namespace mcvo
