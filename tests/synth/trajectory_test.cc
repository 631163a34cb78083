#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "mcvo/geometry/so3.h"
#include "mcvo/synth/trajectory.h"
#include "mcvo/util/error.h"

namespace mcvo::synth {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// A 200 m x 120 m block driven counter-clockwise (four 90 degree left turns).
TrajectorySpec UrbanLoop(uint64_t seed = 7) {
  TrajectorySpec spec;
  spec.waypoints = {{0, 0, 0}, {200, 0, 0}, {200, 120, 0}, {0, 120, 0}};
  spec.closed = true;
  spec.seed = seed;
  return spec;
}

// Open drive: right turn, a short 24 m segment between two turns (radius
// limited by the segment), a 45 degree turn.
TrajectorySpec OpenDrive() {
  TrajectorySpec spec;
  spec.waypoints = {{0, 0, 0}, {150, 0, 0}, {150, -24, 0}, {250, -24, 0}, {330, 56, 0}};
  spec.seed = 3;
  return spec;
}

// A hand-held loop through 2.4 m wide corridors around a 30 m x 12 m block.
TrajectorySpec CorridorLoop(uint64_t seed = 11) {
  TrajectorySpec spec;
  spec.waypoints = {{0, 0, 0}, {30, 0, 0}, {30, 12, 0}, {10, 12, 0}, {10, 6, 0}, {0, 6, 0}};
  spec.closed = true;
  spec.style = MotionStyle::kHandheld;
  spec.speed_mps = 1.2;
  spec.rig_height_m = 1.5;
  spec.seed = seed;
  return spec;
}

struct Samples {
  double dt_s = 0.0;
  std::vector<Rigid3d> poses;
};

Samples Sample(const SmoothTrajectory& trajectory, int64_t dt_ns, int64_t t0_ns, int64_t t1_ns) {
  Samples samples;
  samples.dt_s = dt_ns * 1e-9;
  for (int64_t t = t0_ns; t <= t1_ns; t += dt_ns) samples.poses.push_back(trajectory.WorldFromRig(t));
  return samples;
}

// Largest norms of the first three finite differences of position (m/s, m/s^2, m/s^3).
struct Maxima {
  double speed = 0.0, accel = 0.0, jerk = 0.0, lateral_accel = 0.0;
};
Maxima DifferenceMaxima(const Samples& s) {
  Maxima m;
  const double h = s.dt_s;
  for (size_t i = 1; i + 2 < s.poses.size(); ++i) {
    const Eigen::Vector3d& p0 = s.poses[i - 1].translation;
    const Eigen::Vector3d& p1 = s.poses[i].translation;
    const Eigen::Vector3d& p2 = s.poses[i + 1].translation;
    const Eigen::Vector3d& p3 = s.poses[i + 2].translation;
    const Eigen::Vector3d v = (p2 - p0) / (2 * h);
    const Eigen::Vector3d a = (p2 - 2 * p1 + p0) / (h * h);
    const Eigen::Vector3d j = (p3 - 3 * p2 + 3 * p1 - p0) / (h * h * h);
    m.speed = std::max(m.speed, v.norm());
    m.accel = std::max(m.accel, a.norm());
    m.jerk = std::max(m.jerk, j.norm());
    const Eigen::Vector2d vh = v.head<2>().normalized(), ah = a.head<2>();
    m.lateral_accel = std::max(m.lateral_accel, std::abs(vh.x() * ah.y() - vh.y() * ah.x()));
  }
  return m;
}

// Largest angular rate (rad/s) and angular acceleration (rad/s^2) from the rotations.
std::pair<double, double> AngularMaxima(const Samples& s) {
  double rate = 0.0, accel = 0.0;
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  for (size_t i = 0; i + 1 < s.poses.size(); ++i) {
    const Eigen::Vector3d omega = So3Log(s.poses[i].rotation.conjugate() * s.poses[i + 1].rotation) / s.dt_s;
    rate = std::max(rate, omega.norm());
    if (i > 0) accel = std::max(accel, (omega - previous).norm() / s.dt_s);
    previous = omega;
  }
  return {rate, accel};
}

// Horizontal distance from p to the closest segment of the (closed) polyline.
double DistanceToPolyline(const Eigen::Vector3d& p, const std::vector<Eigen::Vector3d>& w, bool closed) {
  double best = 1e300;
  const size_t n = closed ? w.size() : w.size() - 1;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d a = w[i].head<2>(), b = w[(i + 1) % w.size()].head<2>();
    const double u = std::clamp((p.head<2>() - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    best = std::min(best, (p.head<2>() - (a + u * (b - a))).norm());
  }
  return best;
}

// Tilt of the rig z axis away from world -z, rad.
double Tilt(const Rigid3d& world_from_rig) {
  const Eigen::Vector3d z = world_from_rig.RotationMatrix().col(2);
  return std::acos(std::clamp(-z.z(), -1.0, 1.0));
}

TEST(SmoothTrajectory, RigFrameConventionAtStart) {
  const SmoothTrajectory trajectory(UrbanLoop());
  const Eigen::Matrix3d r = trajectory.WorldFromRig(0).RotationMatrix();
  EXPECT_GT(r.col(0).dot(Eigen::Vector3d::UnitX()), std::cos(1.0 * kDeg));   // forward = +x
  EXPECT_GT(r.col(1).dot(-Eigen::Vector3d::UnitY()), std::cos(1.0 * kDeg));  // right = -y
  EXPECT_GT(r.col(2).dot(-Eigen::Vector3d::UnitZ()), std::cos(1.0 * kDeg));  // down = -z
  const Eigen::Vector3d p = trajectory.WorldFromRig(0).translation;
  EXPECT_NEAR(p.y(), 0.0, 1e-9);  // on the first segment, after the corner blend
  EXPECT_GT(p.x(), 5.0);
  EXPECT_NEAR(p.z(), 1.2, 0.01);
}

TEST(SmoothTrajectory, StraightPartsFollowThePolyline) {
  for (const TrajectorySpec& spec : {UrbanLoop(), OpenDrive()}) {
    const SmoothTrajectory trajectory(spec);
    const Samples samples = Sample(trajectory, 1000000, 0, trajectory.DurationNs());
    const auto& w = spec.waypoints;
    const size_t segments = spec.closed ? w.size() : w.size() - 1;
    for (size_t i = 0; i < segments; ++i) {
      const Eigen::Vector2d a = w[i].head<2>(), b = w[(i + 1) % w.size()].head<2>();
      const Eigen::Vector2d mid = 0.5 * (a + b), dir = (b - a).normalized();
      int near = 0;
      for (const Rigid3d& pose : samples.poses) {
        const Eigen::Vector2d d = pose.translation.head<2>() - mid;
        if (std::abs(d.dot(dir)) > 0.5 || std::abs(d.x() * dir.y() - d.y() * dir.x()) > 1.0) continue;
        ++near;
        EXPECT_LT(std::abs(d.x() * dir.y() - d.y() * dir.x()), 0.01) << "segment " << i;
      }
      EXPECT_GT(near, 10) << "segment " << i;
    }
    // Open routes start and end at the end waypoints.
    if (!spec.closed) {
      EXPECT_LT((samples.poses.front().translation.head<2>() - w.front().head<2>()).norm(), 1e-9);
      EXPECT_LT((trajectory.WorldFromRig(trajectory.DurationNs()).translation.head<2>() - w.back().head<2>())
                    .norm(),
                1e-6);
    }
  }
}

TEST(SmoothTrajectory, VehicleDynamicsBounded) {
  for (const TrajectorySpec& spec : {UrbanLoop(), OpenDrive()}) {
    const SmoothTrajectory trajectory(spec);
    // 10 ms steps over one traversal, plus a few steps across the loop seam.
    const int64_t past_seam = spec.closed ? 50000000 : 0;  // an open route stops at its end
    const Samples samples = Sample(trajectory, 10000000, 0, trajectory.DurationNs() + past_seam);
    const Maxima m = DifferenceMaxima(samples);
    const auto [rate, angular_accel] = AngularMaxima(samples);
    std::printf(
        "[measured] %s: length %.1f m, duration %.2f s, max speed %.3f m/s, accel %.3f m/s^2, "
        "lateral %.3f m/s^2, jerk %.3f m/s^3, angular rate %.2f deg/s, angular accel %.2f deg/s^2\n",
        spec.closed ? "urban loop" : "open drive", trajectory.LengthM(), trajectory.DurationNs() * 1e-9,
        m.speed, m.accel, m.lateral_accel, m.jerk, rate / kDeg, angular_accel / kDeg);
    EXPECT_LT(m.speed, spec.speed_mps * 1.001);
    EXPECT_LT(m.accel, 3.0);
    EXPECT_LT(m.lateral_accel, spec.max_lateral_accel_mps2 * 1.03);
    EXPECT_LT(m.jerk, 10.0);
    EXPECT_LT(rate, 30.0 * kDeg);
    EXPECT_LT(angular_accel, 60.0 * kDeg);
  }
}

TEST(SmoothTrajectory, CruiseSpeedOnLongStraights) {
  const TrajectorySpec spec = UrbanLoop();
  const SmoothTrajectory trajectory(spec);
  const double duration_s = trajectory.DurationNs() * 1e-9;
  int checked = 0;
  double slowest_in_turn = 1e9;
  for (double t = 0.0; t < duration_s; t += 0.05) {
    const int64_t t_ns = static_cast<int64_t>(t * 1e9);
    const Eigen::Vector3d p = trajectory.WorldFromRig(t_ns).translation;
    const double speed = trajectory.VelocityInWorld(t_ns).norm();
    // Middles of the four long sides: (100, 0), (200, 60), (100, 120), (0, 60).
    const bool middle = (std::abs(p.x() - 100.0) < 10.0 && (p.y() < 1.0 || p.y() > 119.0)) ||
                        (std::abs(p.y() - 60.0) < 10.0 && (p.x() < 1.0 || p.x() > 199.0));
    if (middle) {
      ++checked;
      EXPECT_NEAR(speed, spec.speed_mps, 0.02 * spec.speed_mps) << "t " << t;
    }
    slowest_in_turn = std::min(slowest_in_turn, speed);
  }
  EXPECT_GT(checked, 50);
  // Slows down for the 90 degree turns (v^2 / r <= 2.5 with r ~ 10 m: about 5 m/s).
  EXPECT_LT(slowest_in_turn, 6.0);
  EXPECT_GT(slowest_in_turn, 3.0);
}

TEST(SmoothTrajectory, ClosedLoopSeamIsSmooth) {
  for (const TrajectorySpec& spec : {UrbanLoop(), CorridorLoop()}) {
    const SmoothTrajectory trajectory(spec);
    const int64_t duration = trajectory.DurationNs();
    const Rigid3d start = trajectory.WorldFromRig(0);
    for (const int64_t t : {duration, duration - 1, 2 * duration}) {
      const Rigid3d pose = trajectory.WorldFromRig(t);
      EXPECT_LT((pose.translation - start.translation).norm(), 1e-3);
      EXPECT_LT(RotationAngle(pose.rotation.conjugate() * start.rotation), 0.01 * kDeg);
    }
    // Velocity and angular velocity are continuous across the seam.
    const Eigen::Vector3d v_before = trajectory.VelocityInWorld(duration - 1000000);
    const Eigen::Vector3d v_after = trajectory.VelocityInWorld(duration + 1000000);
    EXPECT_LT((v_before - v_after).norm(), 0.01);
    const Eigen::Vector3d w_before = trajectory.AngularVelocityInRig(duration - 1000000);
    const Eigen::Vector3d w_after = trajectory.AngularVelocityInRig(duration + 1000000);
    EXPECT_LT((w_before - w_after).norm(), 0.01);
    EXPECT_NEAR(trajectory.VelocityInWorld(0).norm(), trajectory.VelocityInWorld(duration - 1).norm(), 1e-3);
  }
}

TEST(SmoothTrajectory, OpenRouteHoldsItsEndPoses) {
  const SmoothTrajectory trajectory(OpenDrive());
  const int64_t duration = trajectory.DurationNs();
  const Rigid3d start = trajectory.WorldFromRig(0), end = trajectory.WorldFromRig(duration);
  for (const int64_t t : {int64_t{-5}, int64_t{-1000000000}}) {
    EXPECT_EQ(trajectory.WorldFromRig(t).ToMatrix4(), start.ToMatrix4());
  }
  for (const int64_t t : {duration + 1, duration + int64_t{3000000000}}) {
    EXPECT_EQ(trajectory.WorldFromRig(t).ToMatrix4(), end.ToMatrix4());
    EXPECT_EQ(trajectory.VelocityInWorld(t), Eigen::Vector3d::Zero());
  }
  EXPECT_NEAR(trajectory.VelocityInWorld(5000000000).norm(), 10.0, 0.2);  // first straight
}

TEST(SmoothTrajectory, VelocityApisMatchThePoses) {
  const SmoothTrajectory trajectory(UrbanLoop());
  const int64_t step = 1000000;  // 1 ms
  for (int64_t t = 0; t < trajectory.DurationNs(); t += 777000000) {
    const Rigid3d before = trajectory.WorldFromRig(t - step), after = trajectory.WorldFromRig(t + step);
    if (t == 0) continue;  // the pose before t = 0 is held
    const Eigen::Vector3d velocity = (after.translation - before.translation) / (2e-9 * step);
    EXPECT_LT((trajectory.VelocityInWorld(t) - velocity).norm(), 1e-3);
    const Eigen::Vector3d omega = So3Log(before.rotation.conjugate() * after.rotation) / (2e-9 * step);
    EXPECT_LT((trajectory.AngularVelocityInRig(t) - omega).norm(), 1e-4);
    // Rig z is down: a left turn (counter-clockwise seen from above) is a negative rate about rig z.
    EXPECT_LT(trajectory.AngularVelocityInRig(t).z(), 1e-3);
  }
}

TEST(SmoothTrajectory, VehiclePitchAndRollAreSmall) {
  const SmoothTrajectory trajectory(UrbanLoop());
  double max_tilt = 0.0, max_height_error = 0.0;
  for (int64_t t = 0; t < trajectory.DurationNs(); t += 20000000) {
    const Rigid3d pose = trajectory.WorldFromRig(t);
    max_tilt = std::max(max_tilt, Tilt(pose));
    max_height_error = std::max(max_height_error, std::abs(pose.translation.z() - 1.2));
  }
  std::printf("[measured] urban loop: max tilt %.3f deg, max height deviation %.4f m\n", max_tilt / kDeg,
              max_height_error);
  EXPECT_LT(max_tilt, 2.0 * kDeg);
  EXPECT_GT(max_tilt, 0.3 * kDeg);  // the body does roll in turns
  EXPECT_LT(max_height_error, 0.012);
}

TEST(SmoothTrajectory, HandheldSwayBobAndCorridor) {
  const TrajectorySpec spec = CorridorLoop();
  const SmoothTrajectory trajectory(spec);
  const Samples samples = Sample(trajectory, 5000000, 0, trajectory.DurationNs());
  double z_min = 1e9, z_max = -1e9, straight_offset = 0.0, any_offset = 0.0, max_tilt = 0.0, max_look = 0.0;
  for (size_t i = 1; i + 1 < samples.poses.size(); ++i) {
    const Rigid3d& pose = samples.poses[i];
    z_min = std::min(z_min, pose.translation.z());
    z_max = std::max(z_max, pose.translation.z());
    const double offset = DistanceToPolyline(pose.translation, spec.waypoints, true);
    any_offset = std::max(any_offset, offset);
    double to_corner = 1e9;
    for (const Eigen::Vector3d& w : spec.waypoints)
      to_corner = std::min(to_corner, (pose.translation - w).norm());
    if (to_corner > 2.5) straight_offset = std::max(straight_offset, offset);
    max_tilt = std::max(max_tilt, Tilt(pose));
    const Eigen::Vector3d velocity = samples.poses[i + 1].translation - samples.poses[i - 1].translation;
    // Horizontal directions only: the step bob tilts the velocity by up to ~11 degrees.
    const Eigen::Vector2d forward = pose.RotationMatrix().col(0).head<2>().normalized();
    const Eigen::Vector2d motion = velocity.head<2>().normalized();
    max_look = std::max(max_look, std::acos(std::clamp(forward.dot(motion), -1.0, 1.0)));
  }
  const Maxima m = DifferenceMaxima(samples);
  const auto [rate, angular_accel] = AngularMaxima(samples);
  std::printf(
      "[measured] corridor: z in [%.4f, %.4f], offset straight %.4f m, anywhere %.3f m, tilt %.2f deg, "
      "look-vs-motion %.2f deg, speed %.3f, accel %.2f, jerk %.1f, rate %.1f deg/s, ang accel %.0f "
      "deg/s^2\n",
      z_min, z_max, straight_offset, any_offset, max_tilt / kDeg, max_look / kDeg, m.speed, m.accel, m.jerk,
      rate / kDeg, angular_accel / kDeg);
  // Bob of 2-3 cm around the rig height.
  EXPECT_GT(z_max - spec.rig_height_m, 0.015);
  EXPECT_GT(spec.rig_height_m - z_min, 0.015);
  EXPECT_LT(std::max(z_max - spec.rig_height_m, spec.rig_height_m - z_min), 0.03);
  // Lateral sway <= 3 cm on the straights; corner blends (radius ~1.2 m) cut
  // corners by a few decimetres, well inside the 1.2 m half-width.
  EXPECT_LT(straight_offset, 0.03);
  EXPECT_LT(any_offset, 0.5);
  EXPECT_LT(max_tilt, 4.0 * kDeg);
  EXPECT_LT(max_look, 12.0 * kDeg);
  EXPECT_LT(angular_accel, 400.0 * kDeg);
  EXPECT_LT(m.speed, 1.3);
  EXPECT_LT(m.accel, 5.0);
  EXPECT_LT(m.jerk, 50.0);
}

TEST(SmoothTrajectory, DeterministicAndSeeded) {
  for (const TrajectorySpec& spec : {UrbanLoop(5), CorridorLoop(5)}) {
    const SmoothTrajectory a(spec), b(spec);
    TrajectorySpec other_spec = spec;
    other_spec.seed = 6;
    const SmoothTrajectory other(other_spec);
    ASSERT_EQ(a.DurationNs(), b.DurationNs());
    double largest_difference = 0.0;
    for (int64_t t = 0; t < a.DurationNs(); t += 123456789) {
      const Rigid3d pa = a.WorldFromRig(t), pb = b.WorldFromRig(t);
      EXPECT_EQ(pa.translation, pb.translation);
      EXPECT_EQ(pa.rotation.coeffs(), pb.rotation.coeffs());
      largest_difference =
          std::max(largest_difference, (pa.ToMatrix4() - other.WorldFromRig(t).ToMatrix4()).norm());
    }
    EXPECT_GT(largest_difference, 1e-4);
  }
}

TEST(SmoothTrajectory, RejectsUndrivableSpecs) {
  TrajectorySpec spec;
  spec.waypoints = {{0, 0, 0}};
  EXPECT_THROW(SmoothTrajectory{spec}, InputError);
  spec.waypoints = {{0, 0, 0}, {0, 0, 0}, {10, 0, 0}};
  spec.closed = true;
  EXPECT_THROW(SmoothTrajectory{spec}, InputError);  // two distinct points cannot close
  spec.closed = false;
  spec.waypoints = {{0, 0, 0}, {10, 0, 0}, {0, 0.1, 0}};  // U-turn
  EXPECT_THROW(SmoothTrajectory{spec}, InputError);
  spec.waypoints = {{0, 0, 0}, {10, 0, 0}};
  spec.speed_mps = 0.0;
  EXPECT_THROW(SmoothTrajectory{spec}, InputError);
  spec.speed_mps = 10.0;
  const SmoothTrajectory straight(spec);  // two waypoints: one straight, 1 s
  EXPECT_NEAR(straight.LengthM(), 10.0, 1e-12);
  EXPECT_NEAR(straight.DurationNs() * 1e-9, 1.0, 1e-6);
}

}  // namespace
}  // namespace mcvo::synth
