// The initializer's last gate (initializer.h, step 6): a rig solution is
// accepted only when every camera it uses agrees with it.
//
// After the rig window BA, the rig poses are metric and shared by all
// cameras. Camera k's own window SfM (camera_sfm.h: positions in its anchor
// frame, unit travel) times its scale s_k from the rig scale solve must then
// be the BA's trajectory of that camera, seen from its anchor pose:
//   p_k(t) = (world_from_rig(0) * rig_from_cam_k)^-1 * (world_from_rig(t) * rig_from_cam_k).origin
// Measured per camera:
//   - rho_k = argmin sum |p_k(t) - rho q_k(t)|^2 = sum p.q / sum q.q: the
//     scale the BA implies for the camera; rho_k / s_k - 1 is its
//     disagreement with the scale solve;
//   - shape residual: rms |p_k(t) - rho_k q_k(t)| over rms |p_k(t)|: how far
//     the camera's own motion is from the rig's (a wrong SfM, a moving scene
//     filling that camera);
//   - landmarks: the BA's landmarks from that camera's features.
// A camera fails when its scale is not positive and finite, it has fewer
// than min_landmarks, its scale disagrees by more than
// max(disagreement_sigmas x its relative std, min_disagreement), or its
// shape residual exceeds max_shape_residual.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

struct RigConsistencyOptions {
  int min_landmarks = 15;
  double disagreement_sigmas = 4.0;
  double min_disagreement = 0.05;     // relative
  double max_shape_residual = 0.15;   // relative to the camera's travel
};

struct CameraConsistency {
  double scale = 0.0;           // s_k of the scale solve
  double relative_sigma = 0.0;  // its relative std
  double ba_scale = 0.0;        // rho_k
  double disagreement = 0.0;    // rho_k / s_k - 1
  double shape_residual = 0.0;
  int landmarks = 0;
};

// world_from_rig: the BA's window poses (index 0 = the anchor frame);
// anchor_from_cam: the camera's SfM poses over the same frames (unit scale).
// MCVO_CHECKs equal, non-zero lengths.
CameraConsistency MeasureCameraConsistency(const std::vector<Rigid3d>& world_from_rig,
                                           const Rigid3d& cam_from_rig,
                                           const std::vector<Rigid3d>& anchor_from_cam, double scale,
                                           double relative_sigma, int landmarks);

// Why the camera fails the gate (one line without the camera name), or nullopt.
std::optional<std::string> CameraConsistencyFailure(const CameraConsistency& c,
                                                    const RigConsistencyOptions& options);

// How far the camera is beyond the gate: the largest of its test values over
// their bounds (infinite for a scale that is not positive and finite);
// above 1 exactly when CameraConsistencyFailure reports a failure. Picks the
// camera to leave out first.
double CameraConsistencyBadness(const CameraConsistency& c, const RigConsistencyOptions& options);

}  // namespace mcvo
