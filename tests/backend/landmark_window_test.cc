// The estimator's parts on their own (src/backend, private headers):
// LandmarkWindow (frames, landmarks, triangulation, re-anchoring, outliers)
// and WindowProblem (the window BA), on exact observations of a known scene
// seen by the KITTI-360 rig driving straight ahead.
#include "../../src/backend/landmark_window.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "../../src/backend/window_problem.h"
#include "initializer/synthetic_rig_tracks.h"

namespace mcvo::backend_internal {
namespace {

using testing::LoadPresetRig;

// Points around the route (x forward in KITTI-360's rig frame), each with a
// feature id; frames every `step_m` along x.
class WindowFixture : public ::testing::Test {
 protected:
  WindowFixture() : rig_(LoadPresetRig("kitti360")) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> x(6.0, 30.0), y(-12.0, 12.0), z(-3.0, 3.0);
    for (int k = 0; k < 400; ++k) points_.push_back({x(rng), y(rng), z(rng)});
  }

  Rigid3d TruePose(int frame) const {
    Rigid3d pose;
    pose.translation = Eigen::Vector3d(step_m_ * frame, 0.0, 0.0);
    return pose;
  }

  // Exact observations of every point in front of each camera (within 70°
  // of its axis), feature id = camera * 100000 + point index + 1 (shared by
  // all frames of that camera: tracks). Points of image_00 that image_01
  // (the stereo partner) sees too are cross-camera observations: they hold
  // the metric scale, which straight driving alone leaves free.
  RigFrameObservations Observe(int frame) const {
    RigFrameObservations obs;
    obs.frame_index = frame;
    obs.t_ns = int64_t{100000000} * frame;
    obs.cameras.resize(rig_.cameras.size());
    obs.camera_missing.assign(rig_.cameras.size(), false);
    for (int c = 0; c < rig_.NumCameras(); ++c) {
      const Rigid3d cam_from_world = rig_.cameras[c].cam_from_rig * TruePose(frame).Inverse();
      for (size_t p = 0; p < points_.size(); ++p) {
        const Eigen::Vector3d in_cam = cam_from_world * points_[p];
        if (in_cam.z() < in_cam.norm() * std::cos(70.0 * M_PI / 180.0)) continue;
        FeatureObservation f;
        f.id = static_cast<uint64_t>(c) * 100000 + p + 1;
        f.bearing = in_cam.normalized();
        obs.cameras[c].push_back(f);
      }
    }
    const Rigid3d cam1_from_world = rig_.cameras[1].cam_from_rig * TruePose(frame).Inverse();
    for (const FeatureObservation& f : obs.cameras[0]) {
      const Eigen::Vector3d in_cam1 = cam1_from_world * TruePoint(f.id);
      if (in_cam1.z() < in_cam1.norm() * std::cos(70.0 * M_PI / 180.0)) continue;
      CrossCameraObservation x;
      x.camera_a = 0;
      x.id = f.id;
      x.camera_b = 1;
      x.bearing_b = in_cam1.normalized();
      obs.cross_camera.push_back(x);
    }
    return obs;
  }

  WindowFrame* AddFrame(LandmarkWindow* window, int frame, const Rigid3d& pose, bool keyframe = true) {
    WindowFrame* f = window->AcquireFrame();
    f->frame_index = frame;
    f->keyframe = keyframe;
    f->obs = Observe(frame);
    f->SetWorldFromRig(pose);
    window->PushBack(f);
    if (window->frames().size() == 1) {
      window->CreateLandmarks(f);
    } else {
      for (auto& [id, ob] : window->FrameObservations(f)) {
        auto it = window->landmarks().find(id);
        if (it != window->landmarks().end()) it->second.observations.push_back(ob);
      }
    }
    return f;
  }

  Eigen::Vector3d TruePoint(uint64_t id) const { return points_[(id % 100000) - 1]; }

  Rig rig_;
  BackendOptions options_;
  double step_m_ = 1.0;
  std::vector<Eigen::Vector3d> points_;
};

TEST_F(WindowFixture, TriangulatesExactlyWithBaselineAndNotWithout) {
  LandmarkWindow window(rig_.CamFromRig(), options_, 4);
  for (int k = 0; k < 3; ++k) AddFrame(&window, k, TruePose(k));
  ASSERT_GT(window.landmarks().size(), 100u);
  for (const auto& [id, lm] : window.landmarks()) {
    EXPECT_FALSE(lm.triangulated);
    EXPECT_DOUBLE_EQ(lm.inverse_depth, 1.0 / options_.init_depth_m);
  }
  window.TriangulatePending();
  int triangulated = 0;
  double worst_m = 0.0;
  for (const auto& [id, lm] : window.landmarks()) {
    if (!lm.triangulated) continue;
    ++triangulated;
    EXPECT_TRUE(window.UsableInBa(lm));
    worst_m = std::max(worst_m, (window.LandmarkInWorld(lm) - TruePoint(id)).norm());
  }
  // 2 m of baseline to points 6-30 m away: every landmark seen in all three frames.
  EXPECT_GT(triangulated, static_cast<int>(window.landmarks().size() * 9 / 10));
  EXPECT_LT(worst_m, 1e-6);

  // The same scene from 1 cm of motion (under 0.1° of parallax at 6 m):
  // below the 0.5° bound, nothing is triangulated from motion; image_00's
  // landmarks that image_01 sees too still are, from the stereo baseline.
  step_m_ = 0.01;
  LandmarkWindow close(rig_.CamFromRig(), options_, 4);
  for (int k = 0; k < 3; ++k) AddFrame(&close, k, TruePose(k));
  close.TriangulatePending();
  int stereo = 0;
  for (const auto& [id, lm] : close.landmarks()) {
    const bool cross = std::any_of(lm.observations.begin(), lm.observations.end(),
                                   [&](const LandmarkObservation& ob) { return ob.camera != lm.camera; });
    if (!cross) {
      EXPECT_FALSE(lm.triangulated) << id;
    } else if (lm.triangulated) {
      ++stereo;
      EXPECT_LT((close.LandmarkInWorld(lm) - TruePoint(id)).norm(), 1e-6) << id;
    }
  }
  EXPECT_GT(stereo, 20);
}

TEST_F(WindowFixture, RemovingTheAnchorFrameReanchorsWhereThePointWas) {
  LandmarkWindow window(rig_.CamFromRig(), options_, 4);
  for (int k = 0; k < 3; ++k) AddFrame(&window, k, TruePose(k));
  window.TriangulatePending();
  const WindowFrame* first = window.frames().front();
  const WindowFrame* second = window.frames()[1];
  std::map<uint64_t, Eigen::Vector3d> before;
  for (const auto& [id, lm] : window.landmarks()) {
    if (lm.triangulated) before[id] = window.LandmarkInWorld(lm);
  }
  window.RemoveFrameObservations(first);
  window.PopFront();
  int reanchored = 0;
  for (const auto& [id, lm] : window.landmarks()) {
    EXPECT_NE(lm.anchor_frame, first);
    for (const LandmarkObservation& ob : lm.observations) EXPECT_NE(ob.frame, first);
    auto it = before.find(id);
    if (it == before.end() || !lm.triangulated) continue;
    ++reanchored;
    EXPECT_EQ(lm.anchor_frame, second);
    EXPECT_LT((window.LandmarkInWorld(lm) - it->second).norm(), 1e-9);
  }
  EXPECT_GT(reanchored, 100);
  // Points seen only by the removed frame left the window, into the map.
  const std::vector<MapLandmark> left = window.TakeFinishedLandmarks();
  for (const MapLandmark& m : left)
    EXPECT_LT((m.position_world - TruePoint(static_cast<uint64_t>(m.id))).norm(), 1e-6);
  EXPECT_TRUE(window.TakeFinishedLandmarks().empty());
}

TEST_F(WindowFixture, AnOutlierObservationIsRemovedAndTheAnchorKept) {
  LandmarkWindow window(rig_.CamFromRig(), options_, 4);
  for (int k = 0; k < 3; ++k) AddFrame(&window, k, TruePose(k));
  window.TriangulatePending();
  auto it = std::find_if(window.landmarks().begin(), window.landmarks().end(),
                         [](const auto& entry) { return entry.second.triangulated; });
  ASSERT_NE(it, window.landmarks().end());
  WindowLandmark& lm = it->second;
  const size_t observations = lm.observations.size();
  // 2° off (16 px at the virtual focal length): an outlier.
  LandmarkObservation& last = lm.observations.back();
  last.bearing =
      (Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()) * last.bearing).normalized();
  EXPECT_GT(window.ObservationErrorPx(lm, last), options_.outlier_threshold_px);
  window.RemoveOutliers();
  ASSERT_EQ(lm.observations.size(), observations - 1);
  EXPECT_EQ(lm.observations.front().frame, lm.anchor_frame);
  EXPECT_TRUE(lm.triangulated);
}

TEST_F(WindowFixture, BundleAdjustmentRestoresPerturbedPosesAndDepths) {
  LandmarkWindow window(rig_.CamFromRig(), options_, 5);
  std::vector<WindowFrame*> frames;
  for (int k = 0; k < 4; ++k) frames.push_back(AddFrame(&window, k, TruePose(k)));
  window.TriangulatePending();
  // Perturb every frame but the oldest (the gauge) by 5 cm and 0.3°, and every depth by 5 %.
  for (int k = 1; k < 4; ++k) {
    Rigid3d pose = TruePose(k);
    pose.translation += Eigen::Vector3d(0.03, -0.04, 0.02) * (k % 2 == 0 ? 1.0 : -1.0);
    pose.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * M_PI / 180.0, Eigen::Vector3d::UnitZ()));
    frames[k]->SetWorldFromRig(pose);
  }
  for (auto& [id, lm] : window.landmarks()) lm.inverse_depth *= 1.05;
  WindowProblem problem(rig_, options_);
  FrameEstimate estimate;
  ASSERT_TRUE(problem.Solve(&window, false, &estimate));
  EXPECT_LT(estimate.ba_final_cost, 1e-6 * estimate.ba_initial_cost);
  EXPECT_EQ(frames[0]->WorldFromRig().translation, TruePose(0).translation);  // held
  for (int k = 1; k < 4; ++k) {
    EXPECT_LT((frames[k]->WorldFromRig().translation - TruePose(k).translation).norm(), 1e-4) << k;
    EXPECT_LT(frames[k]->WorldFromRig().rotation.angularDistance(Eigen::Quaterniond::Identity()), 1e-5) << k;
  }
  double worst_m = 0.0;
  for (const auto& [id, lm] : window.landmarks()) {
    if (window.UsableInBa(lm))
      worst_m = std::max(worst_m, (window.LandmarkInWorld(lm) - TruePoint(id)).norm());
  }
  EXPECT_LT(worst_m, 1e-2);

  // Marginalising the oldest keyframe leaves a prior; the next solve with
  // it still agrees with the truth.
  problem.MarginalizeOldest(&window);
  window.RemoveFrameObservations(window.frames().front());
  window.PopFront();
  FrameEstimate next;
  ASSERT_TRUE(problem.Solve(&window, false, &next));
  for (int k = 1; k < 4; ++k) {
    EXPECT_LT((frames[k]->WorldFromRig().translation - TruePose(k).translation).norm(), 1e-4) << k;
  }
}

TEST_F(WindowFixture, TheFramePoolHoldsItsCapacityAndReusesReleasedSlots) {
  LandmarkWindow window(rig_.CamFromRig(), options_, 2);
  WindowFrame* a = window.AcquireFrame();
  WindowFrame* b = window.AcquireFrame();
  EXPECT_NE(a, b);
  window.ReleaseFrame(a);
  EXPECT_EQ(window.AcquireFrame(), a);  // the same slot, the same pose address
  EXPECT_DEATH(window.AcquireFrame(), "frame pool of 2 slots exhausted");
}

}  // namespace
}  // namespace mcvo::backend_internal
