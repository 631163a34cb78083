// Far cross-camera matches out of the window BA (BackendOptions::
// cross_camera_min_angle_deg).
#pragma once

#include "mcvo/camera/camera.h"
#include "mcvo/map/observations.h"

namespace mcvo {
namespace backend_internal {

// The angle, in degrees, at which the rays of camera a's bearing and camera
// b's bearing (each in its own camera frame) meet, both taken from their
// camera centres in the rig frame: about disparity / focal on a rectified
// pair. 0 when they do not converge (parallel or diverging rays).
double CrossCameraRayAngleDeg(const Camera& a, const Eigen::Vector3d& bearing_a, const Camera& b,
                              const Eigen::Vector3d& bearing_b);

// Removes from obs->cross_camera every match whose rays meet at less than
// min_angle_deg (CrossCameraRayAngleDeg, camera a's bearing of the same
// feature id from obs->cameras), and every match whose feature camera a does
// not list. Keeps the order of the rest. min_angle_deg <= 0: nothing.
void DropFarCrossCameraObservations(const Rig& rig, double min_angle_deg, RigFrameObservations* obs);

}  // namespace backend_internal
}  // namespace mcvo
