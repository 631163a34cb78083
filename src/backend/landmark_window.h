// The estimator's window (estimator.h steps 2, 4 and the bookkeeping of 5):
// the frames it holds, in a fixed pool of slots, and the landmarks they
// observe, anchored in the keyframe and camera that first saw them as an
// inverse distance along the anchor bearing. It triangulates, re-anchors a
// landmark when its anchor frame leaves, drops outlier observations, and
// hands out the keyframes and landmarks that leave it (the sparse map).
// It owns no optimisation: window_problem.h adjusts the parameters this
// window stores (frame poses, inverse depths) in place.
// Private to the back end (src/backend); deterministic: landmarks are kept
// by feature id and frames in pool slots whose addresses never change.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "mcvo/backend/backend_options.h"
#include "mcvo/backend/estimator.h"
#include "mcvo/backend/factors.h"
#include "mcvo/geometry/rigid3d.h"
#include "mcvo/map/observations.h"
#include "mcvo/map/sparse_map.h"

namespace mcvo::backend_internal {

// Landmarks closer than this or farther than kMaxLandmarkDistanceM are not
// used (behind the camera, at infinity, or diverged).
inline constexpr double kMinLandmarkDistanceM = 0.1;
inline constexpr double kMaxLandmarkDistanceM = 1000.0;

struct WindowFrame {
  int frame_index = 0;
  int64_t t_ns = 0;
  int segment = 0;
  bool keyframe = false;
  // A pose known from elsewhere (Estimator::StartFromPoses): held constant
  // in the window's BA and marginalisation, never rescaled.
  bool pose_fixed = false;
  std::array<double, kPoseParamSize> pose{};  // world_from_rig, a BA parameter block
  RigFrameObservations obs;

  Rigid3d WorldFromRig() const { return PoseFromParams(pose.data()); }
  void SetWorldFromRig(const Rigid3d& world_from_rig) { PoseToParams(world_from_rig, pose.data()); }
};

struct LandmarkObservation {
  WindowFrame* frame = nullptr;
  int camera = 0;
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();
};

struct WindowLandmark {
  int camera = 0;  // the camera whose feature it is
  WindowFrame* anchor_frame = nullptr;
  int anchor_camera = 0;
  Eigen::Vector3d anchor_bearing = Eigen::Vector3d::UnitZ();
  double inverse_depth = 0.0;  // a BA parameter (copied out while solving, see window_problem.h)
  bool triangulated = false;
  std::vector<LandmarkObservation> observations;  // the anchor's included, in frame order
  // Position when the last keyframe that used it left the window: the map's
  // position when the landmark is no longer triangulated when it leaves (its
  // observations left the window one by one).
  std::optional<Eigen::Vector3d> map_position;
};

class LandmarkWindow {
 public:
  // capacity: the most frames the window ever holds at once.
  LandmarkWindow(std::vector<Rigid3d> cam_from_rig, const BackendOptions& options, int capacity);

  // ---- frames: keyframes oldest first, then possibly one non-keyframe.
  // A fresh frame from a free slot (checked: the pool never runs out while
  // every frame is released or pushed).
  WindowFrame* AcquireFrame();
  // A frame that never entered the window goes back to the pool.
  void ReleaseFrame(WindowFrame* frame);
  void PushBack(WindowFrame* frame) { frames_.push_back(frame); }
  void PopFront();
  void PopBack();
  // Every frame and landmark leaves (nothing goes to the map).
  void Clear();
  const std::deque<WindowFrame*>& frames() const { return frames_; }
  int NumKeyframes() const;

  // ---- landmarks, by feature id.
  std::map<uint64_t, WindowLandmark>& landmarks() { return landmarks_; }
  const std::map<uint64_t, WindowLandmark>& landmarks() const { return landmarks_; }

  // ---- geometry
  const std::vector<Rigid3d>& cam_from_rig() const { return cam_from_rig_; }
  Rigid3d WorldFromCam(const WindowFrame& frame, int camera) const;
  Eigen::Vector3d LandmarkInWorld(const WindowLandmark& lm) const;
  // Tangent-plane error of one observation at the virtual focal length, px.
  double ObservationErrorPx(const WindowLandmark& lm, const LandmarkObservation& ob) const;
  // Triangulated, observed often enough, and in the distance range.
  bool UsableInBa(const WindowLandmark& lm) const;
  // Midpoint triangulation over all observation rays; sets the inverse
  // depth along the anchor bearing when the rays are wide enough apart, the
  // point is in front of the anchor and every observation fits.
  bool Triangulate(WindowLandmark* lm) const;
  void TriangulatePending();

  // Observations of the frame's features (own camera and cross-camera), as
  // (feature id, observation), whether or not a landmark exists.
  std::vector<std::pair<uint64_t, LandmarkObservation>> FrameObservations(WindowFrame* frame) const;
  static bool HasObservation(const WindowLandmark& lm, const WindowFrame* frame, int camera);
  // New landmarks for the features of a keyframe that have none, anchored there.
  void CreateLandmarks(WindowFrame* frame);
  // Removes every observation in `frame`; landmarks anchored there are
  // re-anchored in their earliest remaining observation, or leave.
  void RemoveFrameObservations(const WindowFrame* frame);
  // Observations whose error exceeds the threshold are removed; landmarks
  // that end up out of range become untriangulated.
  void RemoveOutliers();

  // Largest rotation between the oldest frame and any later one, degrees.
  double RotationDeg() const;
  // Monocular gauge: the keyframe (not the oldest, not the newest frame
  // unless nothing else is there) farthest from the oldest keyframe; null
  // when every frame is where the oldest is (pure rotation).
  WindowFrame* FarthestFromOldest() const;

  // ---- what leaves: the map
  // A keyframe leaving, with its observations of the landmarks the BA uses
  // (which remember that position as their map position).
  KeyframeEstimate FinishedKeyframe(const WindowFrame* frame);
  // Every landmark with a position leaves (new segment, end of run).
  void FinishAllLandmarks();
  std::vector<MapLandmark> TakeFinishedLandmarks();

 private:
  std::vector<Rigid3d> cam_from_rig_;
  BackendOptions options_;
  // Frames live in a fixed pool allocated once, so their pose blocks have
  // stable addresses whose order depends only on the slot (window_problem.h).
  std::vector<WindowFrame> pool_;
  std::vector<bool> slot_used_;
  std::deque<WindowFrame*> frames_;
  std::map<uint64_t, WindowLandmark> landmarks_;  // ordered: deterministic
  std::vector<MapLandmark> finished_landmarks_;
};

}  // namespace mcvo::backend_internal
