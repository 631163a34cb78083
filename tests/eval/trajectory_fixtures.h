// In-memory trajectories for the eval tests (no file readers involved).
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>

#include "mcvo/geometry/so3.h"
#include "mcvo/io/trajectory_io.h"

namespace mcvo::testing {

inline constexpr double kPi = 3.14159265358979323846;

// n poses at t = t0 + k * dt_ns; the pose comes from `pose_at(k)`.
inline Trajectory MakeTrajectory(int n, const std::function<Rigid3d(int)>& pose_at, int64_t dt_ns = 100000000,
                                 int64_t t0_ns = 1000000000) {
  Trajectory trajectory;
  trajectory.has_time = true;
  for (int k = 0; k < n; ++k) {
    StampedPose pose;
    pose.t_ns = t0_ns + k * dt_ns;
    pose.world_from_body = pose_at(k);
    trajectory.poses.push_back(pose);
  }
  return trajectory;
}

// A helix of radius 10 m about the world z axis: |p_xy| = 10 for every pose,
// 0.1 rad of turn and 0.05 m of climb per pose; the body yaws with the turn
// and rolls slowly, so the positions span 3-D and the rotations vary.
inline Rigid3d HelixPose(int k) {
  const double a = 0.1 * k;
  const Eigen::Vector3d position(10.0 * std::cos(a), 10.0 * std::sin(a), 0.05 * k);
  const Eigen::Quaterniond rotation =
      So3Exp(Eigen::Vector3d(0.0, 0.0, a)) * So3Exp(Eigen::Vector3d(0.01 * k, 0.0, 0.0));
  return Rigid3d(rotation, position);
}

inline Trajectory Helix(int n) { return MakeTrajectory(n, HelixPose); }

// The same trajectory with every pose mapped by new_world_from_world
// (positions scaled by `scale` about the origin first).
inline Trajectory Transformed(const Trajectory& in, const Rigid3d& new_world_from_world, double scale = 1.0) {
  Trajectory out = in;
  for (StampedPose& pose : out.poses) {
    Rigid3d scaled = pose.world_from_body;
    scaled.translation *= scale;
    pose.world_from_body = new_world_from_world * scaled;
  }
  return out;
}

}  // namespace mcvo::testing
