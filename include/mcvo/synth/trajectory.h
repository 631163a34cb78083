// Smooth (C2) rig trajectories through a scene route, sampled at any time.
//
// The route waypoints are smoothed into a C2 curve (position continuous up to
// the second derivative, so velocity and acceleration are continuous and
// finite-difference tests of IMU-like quantities behave), traversed with a
// speed profile that slows down in turns. The rig frame is the KITTI-360
// vehicle convention: x forward, y right, z down; the world is z up.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "mcvo/geometry/rigid3d.h"
#include "mcvo/synth/scene.h"

namespace mcvo::synth {

struct TrajectorySpec {
  std::vector<Eigen::Vector3d> waypoints;  // ground-level route (z = 0), at least 2
  bool closed = false;                     // route returns to its start (first waypoint)
  MotionStyle style = MotionStyle::kVehicle;
  double speed_mps = 10.0;                 // cruise speed
  double max_lateral_accel_mps2 = 2.5;     // vehicle: slows down in turns to respect this
  double rig_height_m = 1.2;
  uint64_t seed = 0;                       // small pitch/roll/sway variation
};

class SmoothTrajectory {
 public:
  explicit SmoothTrajectory(const TrajectorySpec& spec);

  // Pose of the rig at time t (t = 0 at the start of the route). Times past
  // the end: closed routes go round again, open routes stop at the end
  // (the rig stands still).
  Rigid3d WorldFromRig(int64_t t_ns) const;
  // Time to traverse the route once, ns.
  int64_t DurationNs() const;
  double LengthM() const;

 private:
  // Arc-length parametrised C2 curve and the time -> arc length map.
  std::vector<double> knots_s_;            // arc length at curve samples
  std::vector<Eigen::Vector3d> samples_;   // dense C2 curve samples (see .cc)
  std::vector<double> time_s_;             // time at each sample
  TrajectorySpec spec_;
  double length_m_ = 0.0;
  double duration_s_ = 0.0;
};

}  // namespace mcvo::synth
