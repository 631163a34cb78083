// Smooth (C2) rig trajectories through a scene route, sampled at any time.
//
// The route waypoints are smoothed into a C2 curve (position continuous up to
// the second derivative, so velocity and acceleration are continuous and
// finite-difference tests of IMU-like quantities behave), traversed with a
// speed profile that slows down in turns. The rig frame is the KITTI-360
// vehicle convention: x forward, y right, z down; the world is z up.
//
// Method (details in trajectory.cc):
//  * Path: the polyline stays straight between waypoints; each waypoint with
//    a turn gets a corner blend whose curvature is a smooth bump in arc length
//    (quintic smootherstep ramp in, constant, ramp out; clothoid-like), so the
//    curvature is C2 in arc length and the position C4. The bump integrates to
//    the corner's turn angle and is symmetric, so the blend leaves and rejoins
//    the two adjacent segments exactly (closed routes close exactly). Minimum
//    radius: ~10 m for vehicles, ~1.2 m hand-held, reduced where half the
//    adjacent segment is too short.
//  * Speed: v^2 limited by the cruise speed, the lateral acceleration and (for
//    vehicles) the yaw rate and yaw acceleration; a forward/backward pass bounds dv/dt; the result
//    is eroded and then smoothed with a C2 kernel (which keeps both the limit
//    and the acceleration bound). Starts at the profile speed (cruise on a
//    straight start); closed routes have a periodic profile.
//  * Orientation: yaw along the tangent; vehicle pitch from the longitudinal
//    and roll from the lateral acceleration plus small seeded waves; hand-held
//    sway/bob as sums of seeded sinusoids in arc length (periodic on loops).
#pragma once

#include <array>
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
  double speed_mps = 10.0;              // cruise speed
  double max_lateral_accel_mps2 = 2.5;  // slows down in turns to respect this
  double rig_height_m = 1.2;
  uint64_t seed = 0;  // small pitch/roll/sway variation
  // The point of the rig frame (x forward, y right) that follows the route
  // at rig_height_m; its z is not used. The origin by default; `mcvo synth`
  // carries a rig through rooms by the centre of its cameras
  // (synthesize.cc FitRigToRoom), as a person would.
  Eigen::Vector3d route_point_in_rig = Eigen::Vector3d::Zero();
};

// The trajectory `mcvo synth` drives through a scene: its route, closure,
// motion style, cruise speed and rig height, 2.5 m/s^2 lateral acceleration,
// the seed for the pose variation.
TrajectorySpec RouteTrajectorySpec(const SceneWithRoute& scene, uint64_t seed);

class SmoothTrajectory {
 public:
  // Throws InputError for a spec that cannot be driven (fewer than 2 distinct
  // waypoints, 3 for a closed route; a turn sharper than 175 degrees; a
  // non-positive speed or lateral acceleration).
  explicit SmoothTrajectory(const TrajectorySpec& spec);

  // Pose of the rig at time t (t = 0 at the start of the route). Times past
  // the end: closed routes go round again (the pose at t + DurationNs() is
  // exactly the pose at t: the same computation on t modulo the lap), open
  // routes stop at the end (the rig stands still). Negative times: the start pose. Open routes begin
  // at the first waypoint; closed routes at the point where the first
  // segment's straight part begins (the first waypoint itself when the route
  // is straight there). Thread-safe.
  Rigid3d WorldFromRig(int64_t t_ns) const;
  // Time to traverse the route once (one lap of a closed route), ns.
  int64_t DurationNs() const;
  double LengthM() const;

  // Velocity of the rig origin in the world frame, m/s, and angular velocity
  // of the rig expressed in the rig frame, rad/s (world_from_rig' =
  // world_from_rig * hat(omega)). Central differences over +-0.1 ms of the
  // C2 pose; zero while an open route holds its start or end pose.
  Eigen::Vector3d VelocityInWorld(int64_t t_ns) const;
  Eigen::Vector3d AngularVelocityInRig(int64_t t_ns) const;

 private:
  // A corner blend of unit length: positions at kCornerTableSize + 1 uniform
  // steps of the normalised arc length u in [0, 1], in a frame whose x axis
  // is the incoming direction.
  struct Corner {
    double turn_rad = 0.0;
    std::vector<Eigen::Vector2d> unit_table;
  };
  // A piece of the path: straight (corner < 0) or a corner blend.
  struct Piece {
    double s_begin = 0.0;
    double length = 0.0;
    Eigen::Vector2d start = Eigen::Vector2d::Zero();
    double heading = 0.0;  // at the start of the piece, rad from world x
    int corner = -1;
  };
  struct PathPoint {
    Eigen::Vector2d position = Eigen::Vector2d::Zero();
    double heading = 0.0;
    double curvature = 0.0;       // 1/m, positive turning left (counter-clockwise)
    double curvature_rate = 0.0;  // dk/ds, 1/m^2
  };
  // value(s) = sum amplitude * sin(wavenumber * s + phase).
  struct Wave {
    double amplitude = 0.0;
    double wavenumber = 0.0;
    double phase = 0.0;
  };
  enum Channel { kLateral = 0, kVertical, kYaw, kPitch, kRoll, kNumChannels };

  void BuildPath(const std::vector<Eigen::Vector2d>& points, double corner_radius_m);
  void BuildSpeedProfile();
  void BuildWaves();
  PathPoint PathAt(double s) const;
  // Arc length at time t_s in [0, duration], with ds/dt and d2s/dt2.
  double ArcLengthAt(double t_s, double* speed, double* accel) const;
  double WaveSum(Channel channel, double s) const;
  Rigid3d PoseAtSeconds(double t_s) const;
  // Maps t_ns to seconds in [0, duration] (wrap for closed, clamp for open).
  double Seconds(int64_t t_ns) const;

  TrajectorySpec spec_;
  std::vector<Corner> corners_;
  std::vector<Piece> pieces_;
  double length_m_ = 0.0;
  // Speed profile on a uniform arc-length grid (node j at s = j * node_step_m_).
  double node_step_m_ = 0.0;
  std::vector<double> node_time_s_;
  std::vector<double> node_speed_;  // ds/dt
  std::vector<double> node_accel_;  // d2s/dt2
  double duration_s_ = 0.0;
  int64_t duration_ns_ = 0;
  std::array<std::vector<Wave>, kNumChannels> waves_;
};

}  // namespace mcvo::synth
