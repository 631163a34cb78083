// C2 trajectories through a waypoint route (see trajectory.h for the summary).
//
// Path. Between waypoints the path is the straight polyline segment. At a
// waypoint with signed turn angle theta (incoming to outgoing direction,
// positive counter-clockwise) a blend of length L replaces the corner: with
// u = (s - s_entry) / L in [0, 1], the curvature is
//   k(s) = theta / L * b(u),   b = h * ramp, h = 1 / (1 - r),
// where the ramp rises with the quintic smootherstep S(x) = 6x^5 - 15x^4 + 10x^3
// over u in [0, r], stays at 1 and falls symmetrically over [1 - r, 1]. b
// integrates to 1, so the heading turns by exactly theta, and b and its first
// two derivatives vanish at both ends, so the curvature is C2 in s (position
// C4). Because b is symmetric, the chord of the blend lies along the bisector
// and the blend starts and ends at the same distance d from the waypoint:
//   d = L * |c(theta)| / (2 cos(theta / 2)),  c(theta) = int_0^1 exp(i theta B(u)) du,
// with B the integral of b. The blend positions come from a per-corner table
// of that integral (Gauss-Legendre, 5 nodes per table step, error far below
// 1e-9 m). The largest curvature is h |theta| / L, so a desired minimum radius
// R gives L = h |theta| R; L shrinks where d would exceed half of either
// adjacent segment.
//
// Speed. On a uniform arc-length grid: v_lim^2 = min(cruise^2, a_lat / |k|,
// (w_max / |k|)^2, alpha_max / |dk/ds|) (lateral acceleration, yaw rate, yaw
// acceleration v^2 dk/ds at constant speed); a forward and a backward pass bound |d(v^2)/ds| <= 2 a_max
// (periodic for closed routes); a running minimum over +-W followed by an
// average with a C2 kernel (1 - x^2)^3 of the same half-width keeps v^2 below
// v_lim^2 everywhere (each averaged value is a minimum over a window that
// contains the point) and keeps the slope bound, so |dv/dt| <= a_max, and
// makes the profile smooth, so the jerk is bounded. Time at the grid nodes
// integrates 1/v (trapezoid with the end-derivative correction); s(t) between
// nodes is the quintic Hermite of (s, ds/dt, d2s/dt2), which is C2 in t.
//
// Orientation. world_from_rig = Rz(yaw) Ry(-pitch) Rx(roll) Rx(pi): the first
// three give a forward-left-up body (pitch positive nose up, roll positive
// right side down), Rx(pi) turns it into the x-forward, y-right, z-down rig.
// Seeded waves are sums of sinusoids in arc length whose wavelengths come from
// frequencies at cruise speed; on closed routes each wavelength is rounded to
// a whole number of periods per loop so the pose is periodic.
#include "mcvo/synth/trajectory.h"

#include "mcvo/util/hash.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "mcvo/geometry/so3.h"
#include "mcvo/util/error.h"

namespace mcvo::synth {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr int kCornerTableSize = 128;
constexpr double kRampFraction = 0.3;  // r: share of the blend on each curvature ramp
constexpr double kPlateau = 1.0 / (1.0 - kRampFraction);
constexpr double kMaxTurnRad = 175.0 * kDegToRad;
constexpr double kDiffStepS = 1e-4;  // central differences in VelocityInWorld/AngularVelocityInRig

struct StyleParams {
  double corner_radius_m;      // desired minimum radius of a corner blend
  double max_long_accel_mps2;  // |dv/dt| bound before smoothing (smoothing keeps it)
  double smoothing_half_width_m;
  double grid_step_m;  // at most; the grid divides the route length evenly
  double max_yaw_rate_rps;
  double max_yaw_accel_rps2;  // bounds v^2 |dk/ds| (how fast the steering turns)
};

StyleParams ParamsFor(MotionStyle style) {
  if (style == MotionStyle::kVehicle) return {10.0, 1.5, 8.0, 0.05, 28.0 * kDegToRad, 40.0 * kDegToRad};
  const double unlimited = std::numeric_limits<double>::infinity();
  return {1.2, 0.5, 1.5, 0.02, unlimited, unlimited};
}

// One seeded sinusoid family: amplitude and the frequency range at cruise speed.
struct WaveSpec {
  double amplitude;
  double min_hz;
  double max_hz;
};

// Per channel (lateral m, vertical m, yaw, pitch, roll rad): the waves added.
std::vector<WaveSpec> WaveSpecsFor(MotionStyle style, int channel) {
  const double deg = kDegToRad;
  if (style == MotionStyle::kVehicle) {
    switch (channel) {
      case 1:
        return {{0.005, 0.4, 0.8}, {0.003, 0.15, 0.35}};  // road bumps, <= 8 mm
      case 3:
        return {{0.2 * deg, 0.15, 0.4}, {0.08 * deg, 0.6, 1.0}};  // pitch noise
      case 4:
        return {{0.15 * deg, 0.2, 0.5}, {0.06 * deg, 0.6, 1.0}};  // roll noise
      default:
        return {};
    }
  }
  switch (channel) {
    case 0:
      return {{0.015, 0.85, 0.95}, {0.01, 0.3, 0.6}};  // stride sway + drift, <= 2.5 cm
    case 1:
      return {{0.02, 1.7, 1.9}, {0.006, 0.3, 0.5}};  // step bob ~1.8 Hz, <= 2.6 cm
    case 2:
      return {{3.0 * deg, 0.3, 0.6}, {1.5 * deg, 0.6, 1.0}};  // yaw sway <= 4.5 deg
    case 3:
      return {{2.0 * deg, 0.3, 0.6}, {0.8 * deg, 0.6, 1.0}};  // pitch sway <= 2.8 deg
    case 4:
      return {{1.2 * deg, 0.3, 0.6}, {0.6 * deg, 0.6, 1.0}};  // roll sway <= 1.8 deg
    default:
      return {};
  }
}

// Deterministic uniform doubles in [0, 1) from (seed, index) (util/hash.h),
// the same on every platform and standard library.
double HashUniform(uint64_t seed, uint64_t index) { return UnitFromHash(HashWords({seed, index})); }

double SmootherStep(double x) { return x * x * x * (x * (6.0 * x - 15.0) + 10.0); }
// Integral of SmootherStep from 0 to x (1/2 at x = 1).
double SmootherStepIntegral(double x) { return x * x * x * x * (x * (x - 3.0) + 2.5); }

// Normalised curvature b(u) (integral 1 over [0, 1]) and its integral B(u).
double Bump(double u) {
  if (u <= 0.0 || u >= 1.0) return 0.0;
  if (u < kRampFraction) return kPlateau * SmootherStep(u / kRampFraction);
  if (u > 1.0 - kRampFraction) return kPlateau * SmootherStep((1.0 - u) / kRampFraction);
  return kPlateau;
}
// db/du.
double BumpDerivative(double u) {
  const auto ramp = [](double x) { return 30.0 * x * x * (1.0 - x) * (1.0 - x) / kRampFraction; };
  if (u <= 0.0 || u >= 1.0) return 0.0;
  if (u < kRampFraction) return kPlateau * ramp(u / kRampFraction);
  if (u > 1.0 - kRampFraction) return -kPlateau * ramp((1.0 - u) / kRampFraction);
  return 0.0;
}
double BumpIntegral(double u) {
  if (u <= 0.0) return 0.0;
  if (u >= 1.0) return 1.0;
  if (u < kRampFraction) return kPlateau * kRampFraction * SmootherStepIntegral(u / kRampFraction);
  if (u > 1.0 - kRampFraction) {
    return 1.0 - kPlateau * kRampFraction * SmootherStepIntegral((1.0 - u) / kRampFraction);
  }
  return kPlateau * (0.5 * kRampFraction + (u - kRampFraction));
}

// int_{u0}^{u1} (cos, sin)(theta B(u)) du by 5-point Gauss-Legendre.
Eigen::Vector2d IntegrateUnitCorner(double theta, double u0, double u1) {
  static constexpr double kNodes[5] = {0.0, -0.5384693101056831, 0.5384693101056831, -0.9061798459389640,
                                       0.9061798459389640};
  static constexpr double kWeights[5] = {0.5688888888888889, 0.4786286704993665, 0.4786286704993665,
                                         0.2369268850561891, 0.2369268850561891};
  const double half = 0.5 * (u1 - u0);
  const double mid = 0.5 * (u1 + u0);
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (int i = 0; i < 5; ++i) {
    const double heading = theta * BumpIntegral(mid + half * kNodes[i]);
    sum += kWeights[i] * Eigen::Vector2d(std::cos(heading), std::sin(heading));
  }
  return half * sum;
}

Eigen::Vector2d Direction(double heading) { return {std::cos(heading), std::sin(heading)}; }
Eigen::Vector2d Rotate(double angle, const Eigen::Vector2d& v) {
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
}

// Quintic Hermite on one interval: value, first and second derivative at x in
// [0, h] from (value, d/dx, d2/dx2) at both ends.
void QuinticHermite(double h, double p0, double v0, double a0, double p1, double v1, double a1, double x,
                    double* p, double* v, double* a) {
  const double dp = p1 - p0, hv0 = h * v0, hv1 = h * v1, hha0 = h * h * a0, hha1 = h * h * a1;
  const double c2 = 0.5 * hha0;
  const double c3 = 10.0 * dp - 6.0 * hv0 - 4.0 * hv1 - 1.5 * hha0 + 0.5 * hha1;
  const double c4 = -15.0 * dp + 8.0 * hv0 + 7.0 * hv1 + 1.5 * hha0 - hha1;
  const double c5 = 6.0 * dp - 3.0 * hv0 - 3.0 * hv1 - 0.5 * hha0 + 0.5 * hha1;
  const double tau = x / h;
  *p = p0 + tau * (hv0 + tau * (c2 + tau * (c3 + tau * (c4 + tau * c5))));
  *v = (hv0 + tau * (2.0 * c2 + tau * (3.0 * c3 + tau * (4.0 * c4 + tau * 5.0 * c5)))) / h;
  *a = (2.0 * c2 + tau * (6.0 * c3 + tau * (12.0 * c4 + tau * 20.0 * c5))) / (h * h);
}

}  // namespace

TrajectorySpec RouteTrajectorySpec(const SceneWithRoute& scene, uint64_t seed) {
  TrajectorySpec spec;
  spec.waypoints = scene.waypoints;
  spec.closed = scene.route_closed;
  spec.style = scene.style;
  spec.speed_mps = scene.speed_mps;
  spec.max_lateral_accel_mps2 = 2.5;
  spec.rig_height_m = scene.rig_height_m;
  spec.seed = seed;
  return spec;
}

SmoothTrajectory::SmoothTrajectory(const TrajectorySpec& spec) : spec_(spec) {
  if (!(spec.speed_mps > 0.0) || !std::isfinite(spec.speed_mps)) {
    MCVO_THROW_INPUT("trajectory: speed_mps must be positive and finite, got ", spec.speed_mps);
  }
  if (!(spec.max_lateral_accel_mps2 > 0.0)) {
    MCVO_THROW_INPUT("trajectory: max_lateral_accel_mps2 must be positive, got ",
                     spec.max_lateral_accel_mps2);
  }
  if (!std::isfinite(spec.rig_height_m)) MCVO_THROW_INPUT("trajectory: rig_height_m must be finite");
  if (!spec.route_point_in_rig.allFinite()) MCVO_THROW_INPUT("trajectory: route_point_in_rig must be finite");
  std::vector<Eigen::Vector2d> points;
  for (const Eigen::Vector3d& w : spec.waypoints) {
    if (!w.allFinite()) MCVO_THROW_INPUT("trajectory: waypoint ", points.size(), " is not finite");
    const Eigen::Vector2d p = w.head<2>();
    if (points.empty() || (p - points.back()).norm() > 1e-6) points.push_back(p);
  }
  if (spec.closed && points.size() > 1 && (points.front() - points.back()).norm() <= 1e-6) points.pop_back();
  const size_t needed = spec.closed ? 3 : 2;
  if (points.size() < needed) {
    MCVO_THROW_INPUT("trajectory: need at least ", needed, " distinct waypoints for a ",
                     spec.closed ? "closed" : "open", " route, got ", points.size());
  }
  BuildPath(points, ParamsFor(spec.style).corner_radius_m);
  BuildSpeedProfile();
  BuildWaves();
}

void SmoothTrajectory::BuildPath(const std::vector<Eigen::Vector2d>& points, double corner_radius_m) {
  const int n = static_cast<int>(points.size());
  const int num_segments = spec_.closed ? n : n - 1;
  std::vector<double> seg_length(num_segments), seg_heading(num_segments);
  for (int i = 0; i < num_segments; ++i) {
    const Eigen::Vector2d delta = points[(i + 1) % n] - points[i];
    seg_length[i] = delta.norm();
    seg_heading[i] = std::atan2(delta.y(), delta.x());
  }
  // Corner at vertex i: blend length and tangent distance d (0: no blend).
  std::vector<double> blend_length(n, 0.0), tangent_distance(n, 0.0);
  std::vector<int> corner_of_vertex(n, -1);
  for (int i = 0; i < n; ++i) {
    if (!spec_.closed && (i == 0 || i == n - 1)) continue;
    const int in = (i - 1 + num_segments) % num_segments;
    const double theta = std::remainder(seg_heading[i] - seg_heading[in], 2.0 * kPi);
    if (std::abs(theta) > kMaxTurnRad) {
      MCVO_THROW_INPUT("trajectory: waypoint ", i, " turns by ", theta / kDegToRad,
                       " degrees; turns sharper than 175 degrees are not supported");
    }
    if (std::abs(theta) < 1e-9) continue;
    Corner corner;
    corner.turn_rad = theta;
    corner.unit_table.resize(kCornerTableSize + 1);
    corner.unit_table[0].setZero();
    for (int j = 0; j < kCornerTableSize; ++j) {
      corner.unit_table[j + 1] =
          corner.unit_table[j] +
          IntegrateUnitCorner(theta, double(j) / kCornerTableSize, double(j + 1) / kCornerTableSize);
    }
    const double chord_per_length = corner.unit_table.back().norm();
    const double d_per_length = chord_per_length / (2.0 * std::cos(0.5 * theta));
    double length = kPlateau * std::abs(theta) * corner_radius_m;
    const double d_max = 0.5 * std::min(seg_length[in], seg_length[i]);
    if (length * d_per_length > d_max) length = d_max / d_per_length;
    blend_length[i] = length;
    tangent_distance[i] = length * d_per_length;
    corner_of_vertex[i] = static_cast<int>(corners_.size());
    corners_.push_back(std::move(corner));
  }
  // Pieces: straight part of segment i, then the corner at its end vertex.
  double s = 0.0;
  for (int i = 0; i < num_segments; ++i) {
    const int end = (i + 1) % n;
    const Eigen::Vector2d dir = Direction(seg_heading[i]);
    const double straight = seg_length[i] - tangent_distance[i] - tangent_distance[end];
    if (straight > 1e-12) {
      pieces_.push_back({s, straight, points[i] + tangent_distance[i] * dir, seg_heading[i], -1});
      s += straight;
    }
    if (corner_of_vertex[end] >= 0) {
      pieces_.push_back({s, blend_length[end], points[end] - tangent_distance[end] * dir, seg_heading[i],
                         corner_of_vertex[end]});
      s += blend_length[end];
    }
  }
  length_m_ = s;
  MCVO_CHECK(!pieces_.empty() && length_m_ > 0.0);
}

SmoothTrajectory::PathPoint SmoothTrajectory::PathAt(double s) const {
  s = std::clamp(s, 0.0, length_m_);
  auto it = std::upper_bound(pieces_.begin(), pieces_.end(), s,
                             [](double value, const Piece& piece) { return value < piece.s_begin; });
  const Piece& piece = *(it == pieces_.begin() ? it : it - 1);
  const double along = std::clamp(s - piece.s_begin, 0.0, piece.length);
  PathPoint point;
  if (piece.corner < 0) {
    point.position = piece.start + along * Direction(piece.heading);
    point.heading = piece.heading;
    return point;
  }
  const Corner& corner = corners_[piece.corner];
  const double u = along / piece.length;
  const int j = std::min(static_cast<int>(u * kCornerTableSize), kCornerTableSize - 1);
  const Eigen::Vector2d unit =
      corner.unit_table[j] + IntegrateUnitCorner(corner.turn_rad, double(j) / kCornerTableSize, u);
  point.position = piece.start + piece.length * Rotate(piece.heading, unit);
  point.heading = piece.heading + corner.turn_rad * BumpIntegral(u);
  point.curvature = corner.turn_rad / piece.length * Bump(u);
  point.curvature_rate = corner.turn_rad / (piece.length * piece.length) * BumpDerivative(u);
  return point;
}

void SmoothTrajectory::BuildSpeedProfile() {
  const StyleParams params = ParamsFor(spec_.style);
  const bool closed = spec_.closed;
  const int n = std::max(8, static_cast<int>(std::ceil(length_m_ / params.grid_step_m)));
  const double ds = length_m_ / n;
  node_step_m_ = ds;
  // Independent nodes: closed routes are periodic (node n is node 0).
  const int m = closed ? n : n + 1;
  const auto index = [&](int j) { return closed ? ((j % m) + m) % m : std::clamp(j, 0, m - 1); };

  const double cruise2 = spec_.speed_mps * spec_.speed_mps;
  std::vector<double> v2(m);
  for (int j = 0; j < m; ++j) {
    const PathPoint point = PathAt(j * ds);
    const double k = std::abs(point.curvature), k_rate = std::abs(point.curvature_rate);
    double limit = cruise2;
    if (k > 0.0) {
      limit = std::min({limit, spec_.max_lateral_accel_mps2 / k,
                        (params.max_yaw_rate_rps / k) * (params.max_yaw_rate_rps / k)});
    }
    if (k_rate > 0.0) limit = std::min(limit, params.max_yaw_accel_rps2 / k_rate);
    v2[j] = limit;
  }
  // |d(v^2)/ds| = 2 |dv/dt| <= 2 a_max: forward (acceleration) and backward (braking) passes.
  const double dv2 = 2.0 * params.max_long_accel_mps2 * ds;
  const int sweeps = closed ? 2 * m : m - 1;
  for (int step = 1; step <= sweeps; ++step) {
    const int j = index(step);
    v2[j] = std::min(v2[j], v2[index(step - 1)] + dv2);
  }
  for (int step = closed ? 2 * m - 1 : m - 2; step >= 0; --step) {
    const int j = index(step);
    v2[j] = std::min(v2[j], v2[index(step + 1)] + dv2);
  }
  // Erode then smooth with the same half-width: stays below the limit, keeps the slope bound.
  const int half_width = std::max(1, static_cast<int>(std::lround(params.smoothing_half_width_m / ds)));
  std::vector<double> eroded(m);
  for (int j = 0; j < m; ++j) {
    double lowest = v2[j];
    for (int i = -half_width; i <= half_width; ++i) lowest = std::min(lowest, v2[index(j + i)]);
    eroded[j] = lowest;
  }
  std::vector<double> kernel(2 * half_width + 1);
  double kernel_sum = 0.0;
  for (int i = -half_width; i <= half_width; ++i) {
    const double x = double(i) / (half_width + 1);
    kernel[i + half_width] = (1.0 - x * x) * (1.0 - x * x) * (1.0 - x * x);
    kernel_sum += kernel[i + half_width];
  }
  std::vector<double> smooth(m);
  for (int j = 0; j < m; ++j) {
    double sum = 0.0;
    for (int i = -half_width; i <= half_width; ++i) sum += kernel[i + half_width] * eroded[index(j + i)];
    smooth[j] = sum / kernel_sum;
  }
  // Nodes: ds/dt = v, d2s/dt2 = dv/dt = d(v^2 / 2)/ds.
  node_speed_.resize(n + 1);
  node_accel_.resize(n + 1);
  node_time_s_.resize(n + 1);
  for (int j = 0; j <= n; ++j) {
    node_speed_[j] = std::sqrt(smooth[index(j)]);
    const int lo = closed ? j - 1 : std::max(j - 1, 0);
    const int hi = closed ? j + 1 : std::min(j + 1, n);
    node_accel_[j] = (smooth[index(hi)] - smooth[index(lo)]) / (2.0 * (hi - lo) * ds);
  }
  // t = int ds / v: trapezoid plus the end-derivative correction, with d(1/v)/ds = -a / v^3.
  node_time_s_[0] = 0.0;
  for (int j = 0; j < n; ++j) {
    const double f0 = 1.0 / node_speed_[j], f1 = 1.0 / node_speed_[j + 1];
    const double df0 = -node_accel_[j] * f0 * f0 * f0, df1 = -node_accel_[j + 1] * f1 * f1 * f1;
    node_time_s_[j + 1] = node_time_s_[j] + 0.5 * ds * (f0 + f1) + ds * ds / 12.0 * (df0 - df1);
  }
  duration_s_ = node_time_s_[n];
  duration_ns_ = std::max<int64_t>(1, std::llround(duration_s_ * 1e9));
}

void SmoothTrajectory::BuildWaves() {
  uint64_t draw = 0;
  for (int channel = 0; channel < kNumChannels; ++channel) {
    for (const WaveSpec& wave_spec : WaveSpecsFor(spec_.style, channel)) {
      const double hz =
          wave_spec.min_hz + (wave_spec.max_hz - wave_spec.min_hz) * HashUniform(spec_.seed, draw++);
      Wave wave;
      wave.amplitude = wave_spec.amplitude;
      wave.wavenumber = 2.0 * kPi * hz / spec_.speed_mps;
      if (spec_.closed) {  // whole number of periods per loop: the pose is periodic
        const double cycles = std::max(1.0, std::round(length_m_ * wave.wavenumber / (2.0 * kPi)));
        wave.wavenumber = 2.0 * kPi * cycles / length_m_;
      }
      wave.phase = 2.0 * kPi * HashUniform(spec_.seed, draw++);
      waves_[channel].push_back(wave);
    }
  }
}

double SmoothTrajectory::WaveSum(Channel channel, double s) const {
  double sum = 0.0;
  for (const Wave& wave : waves_[channel]) sum += wave.amplitude * std::sin(wave.wavenumber * s + wave.phase);
  return sum;
}

double SmoothTrajectory::ArcLengthAt(double t_s, double* speed, double* accel) const {
  t_s = std::clamp(t_s, 0.0, duration_s_);
  const int n = static_cast<int>(node_time_s_.size()) - 1;
  const auto it = std::upper_bound(node_time_s_.begin(), node_time_s_.end(), t_s);
  const int j = std::clamp(static_cast<int>(it - node_time_s_.begin()) - 1, 0, n - 1);
  const double s0 = j * node_step_m_;
  const double s1 = j + 1 == n ? length_m_ : (j + 1) * node_step_m_;
  double s = 0.0;
  QuinticHermite(node_time_s_[j + 1] - node_time_s_[j], s0, node_speed_[j], node_accel_[j], s1,
                 node_speed_[j + 1], node_accel_[j + 1], t_s - node_time_s_[j], &s, speed, accel);
  return s;
}

Rigid3d SmoothTrajectory::PoseAtSeconds(double t_s) const {
  // Vehicle body motion: nose up when accelerating, rolls to the outside of a turn.
  constexpr double kPitchPerAccel = 0.35 * kDegToRad;  // rad per m/s^2
  constexpr double kRollPerAccel = 0.3 * kDegToRad;
  double speed = 0.0, accel = 0.0;
  const double s = ArcLengthAt(t_s, &speed, &accel);
  const PathPoint path = PathAt(s);
  const Eigen::Vector2d left(-std::sin(path.heading), std::cos(path.heading));
  const Eigen::Vector2d xy = path.position + WaveSum(kLateral, s) * left;
  const double z = spec_.rig_height_m + WaveSum(kVertical, s);
  const double yaw = path.heading + WaveSum(kYaw, s);
  double pitch = WaveSum(kPitch, s);
  double roll = WaveSum(kRoll, s);
  if (spec_.style == MotionStyle::kVehicle) {
    pitch += kPitchPerAccel * accel;
    roll += kRollPerAccel * speed * speed * path.curvature;
  }
  const Eigen::Quaterniond flu_from_rig(0.0, 1.0, 0.0, 0.0);  // Rx(pi): forward-left-up <- forward-right-down
  const Eigen::Quaterniond world_from_flu = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                                            Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()) *
                                            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
  const Eigen::Quaterniond world_from_rig = world_from_flu * flu_from_rig;
  const Eigen::Vector3d carried(spec_.route_point_in_rig.x(), spec_.route_point_in_rig.y(), 0.0);
  return Rigid3d(world_from_rig, Eigen::Vector3d(xy.x(), xy.y(), z) - world_from_rig * carried);
}

double SmoothTrajectory::Seconds(int64_t t_ns) const {
  if (t_ns <= 0) return 0.0;
  if (spec_.closed) t_ns %= duration_ns_;
  if (t_ns >= duration_ns_) return duration_s_;
  return static_cast<double>(t_ns) * (duration_s_ / static_cast<double>(duration_ns_));
}

Rigid3d SmoothTrajectory::WorldFromRig(int64_t t_ns) const { return PoseAtSeconds(Seconds(t_ns)); }

int64_t SmoothTrajectory::DurationNs() const { return duration_ns_; }

double SmoothTrajectory::LengthM() const { return length_m_; }

namespace {
// The two stencil times around t for a central difference: wrapped on a loop,
// shifted inside [0, duration] on an open route.
std::pair<double, double> Stencil(double t_s, double duration_s, bool closed) {
  if (!closed) t_s = std::clamp(t_s, kDiffStepS, duration_s - kDiffStepS);
  double before = t_s - kDiffStepS, after = t_s + kDiffStepS;
  if (closed) {
    if (before < 0.0) before += duration_s;
    if (after > duration_s) after -= duration_s;
  }
  return {before, after};
}
}  // namespace

Eigen::Vector3d SmoothTrajectory::VelocityInWorld(int64_t t_ns) const {
  if (t_ns < 0 || (!spec_.closed && t_ns > duration_ns_)) return Eigen::Vector3d::Zero();
  const auto [before, after] = Stencil(Seconds(t_ns), duration_s_, spec_.closed);
  return (PoseAtSeconds(after).translation - PoseAtSeconds(before).translation) / (2.0 * kDiffStepS);
}

Eigen::Vector3d SmoothTrajectory::AngularVelocityInRig(int64_t t_ns) const {
  if (t_ns < 0 || (!spec_.closed && t_ns > duration_ns_)) return Eigen::Vector3d::Zero();
  const auto [before, after] = Stencil(Seconds(t_ns), duration_s_, spec_.closed);
  return So3Log(PoseAtSeconds(before).rotation.conjugate() * PoseAtSeconds(after).rotation) /
         (2.0 * kDiffStepS);
}

}  // namespace mcvo::synth
