// Initialisation from overlapping views without motion (see overlap_start.h).
#include "mcvo/initializer/overlap_start.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <vector>

#include <ceres/ceres.h>
#include <ceres/product_manifold.h>

#include "bearing_residual.h"
#include "mcvo/initializer/rig_window_ba.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

using initializer_internal::AngleBetween;
using initializer_internal::FromPoseBlock;
using initializer_internal::PoseBlock;
using initializer_internal::ReprojectionPx;
using initializer_internal::TangentBearingCost;
using initializer_internal::ToPoseBlock;
using initializer_internal::TriangulateMidpoint;

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
// Cross-camera landmarks that count as independent scale measurements at most.
constexpr int kMaxIndependentPoints = 25;
constexpr double kMinRmsPx = 0.5;
constexpr double kFirstPassFactor = 3.0;
constexpr int kPoseIterations = 20;

// A cross-camera landmark: where it is and how well the baseline measures its depth.
struct CrossPoint {
  Eigen::Vector3d point_in_world;
  int camera = 0;      // camera a: whose feature it is
  double angle = 0.0;  // triangulation angle, radians
  double focal = 0.0;  // the smaller focal of the two cameras, px/rad
};

// One bearing of a landmark in one frame, by a rig camera.
struct Sighting {
  int camera = 0;
  uint64_t id = 0;
  Eigen::Vector3d bearing;
};

std::vector<Sighting> SightingsOf(const RigFrameObservations& frame, int num_cameras) {
  std::vector<Sighting> out;
  for (int c = 0; c < num_cameras; ++c) {
    for (const FeatureObservation& f : frame.cameras[static_cast<size_t>(c)])
      out.push_back({c, f.id, f.bearing});
  }
  for (const CrossCameraObservation& x : frame.cross_camera) {
    if (x.camera_b < 0 || x.camera_b >= num_cameras || x.camera_b == x.camera_a) continue;
    out.push_back({x.camera_b, x.id, x.bearing_b});
  }
  return out;
}

// Adds the cross-camera landmarks of `frame` (posed at world_from_rig) that
// are not known yet.
void TriangulateCross(const Rig& rig, const RigFrameObservations& frame, const Rigid3d& world_from_rig,
                      const OverlapStartOptions& options, std::map<uint64_t, CrossPoint>* points) {
  const int num_cameras = rig.NumCameras();
  const double min_angle = options.min_angle_deg * kDegToRad;
  std::map<int, std::map<uint64_t, Eigen::Vector3d>> own;  // camera a -> id -> bearing
  for (const CrossCameraObservation& x : frame.cross_camera) {
    if (x.camera_a < 0 || x.camera_a >= num_cameras || x.camera_b < 0 || x.camera_b >= num_cameras ||
        x.camera_a == x.camera_b || points->count(x.id) != 0) {
      continue;
    }
    auto own_it = own.find(x.camera_a);
    if (own_it == own.end()) {
      std::map<uint64_t, Eigen::Vector3d> bearings;
      for (const FeatureObservation& f : frame.cameras[static_cast<size_t>(x.camera_a)])
        bearings[f.id] = f.bearing;
      own_it = own.emplace(x.camera_a, std::move(bearings)).first;
    }
    const auto bearing_a = own_it->second.find(x.id);
    if (bearing_a == own_it->second.end()) continue;
    const Camera& cam_a = rig.cameras[static_cast<size_t>(x.camera_a)];
    const Camera& cam_b = rig.cameras[static_cast<size_t>(x.camera_b)];
    const Rigid3d a_from_b = cam_a.cam_from_rig * cam_b.cam_from_rig.Inverse();
    const Eigen::Vector3d f_a = bearing_a->second.normalized();
    const Eigen::Vector3d f_b = a_from_b.rotation * x.bearing_b.normalized();
    const std::optional<Eigen::Vector3d> p =
        TriangulateMidpoint(Eigen::Vector3d::Zero(), f_a, a_from_b.translation, f_b);
    if (!p || !p->allFinite() || !(p->norm() <= options.max_depth_m)) continue;
    const double angle = AngleBetween(*p, *p - a_from_b.translation);
    if (!(angle >= min_angle)) continue;
    CrossPoint cp;
    cp.point_in_world = world_from_rig * (cam_a.cam_from_rig.Inverse() * *p);
    cp.camera = x.camera_a;
    cp.angle = angle;
    cp.focal = std::min(cam_a.MeanFocalLength(), cam_b.MeanFocalLength());
    points->emplace(x.id, cp);
  }
}

// Pose-only robust adjustment of one rig frame against fixed landmarks;
// returns the inliers within max_px at the result.
int PoseFrame(const Rig& rig, const std::vector<Sighting>& sightings,
              const std::map<uint64_t, CrossPoint>& points, double max_px, Rigid3d* world_from_rig) {
    using PoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;
  std::map<uint64_t, Eigen::Vector3d> fixed;  // copies Ceres may point at
  for (const Sighting& s : sightings) {
    auto it = points.find(s.id);
    if (it != points.end()) fixed.emplace(s.id, it->second.point_in_world);
  }
  auto error_px = [&](const Rigid3d& pose, const Sighting& s) {
    const Camera& camera = rig.cameras[static_cast<size_t>(s.camera)];
    return ReprojectionPx(pose * camera.cam_from_rig.Inverse(), fixed.at(s.id), s.bearing,
                          camera.MeanFocalLength());
  };
  PoseBlock block = ToPoseBlock(*world_from_rig);
  for (const double threshold : {kFirstPassFactor * max_px, max_px}) {
    const Rigid3d start = FromPoseBlock(block);
    PoseManifold manifold;
    ceres::HuberLoss huber(1.0);
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    for (const Sighting& s : sightings) {
      if (fixed.count(s.id) == 0 || !(error_px(start, s) <= threshold)) continue;
      const Camera& camera = rig.cameras[static_cast<size_t>(s.camera)];
      problem.AddResidualBlock(new TangentBearingCost(s.bearing, camera.MeanFocalLength(), camera.cam_from_rig),
                               &huber, block.data(), fixed.at(s.id).data());
      problem.SetParameterBlockConstant(fixed.at(s.id).data());
    }
    if (problem.NumResidualBlocks() < 6) return 0;
    problem.SetManifold(block.data(), &manifold);
    ceres::Solver::Summary summary;
    ceres::Solve(initializer_internal::DeterministicBaOptions(kPoseIterations), &problem, &summary);
    if (!block.allFinite()) return 0;
  }
  *world_from_rig = FromPoseBlock(block);
  int inliers = 0;
  for (const Sighting& s : sightings) {
    if (fixed.count(s.id) != 0 && error_px(*world_from_rig, s) <= max_px) ++inliers;
  }
  return inliers;
}

}  // namespace

std::optional<InitializationResult> InitialiseFromOverlap(const Rig& rig,
                                                          const std::deque<RigFrameObservations>& window,
                                                          const InitializerOptions& options,
                                                          std::string* reason) {
  const OverlapStartOptions& o = options.overlap_start;
  const int num_cameras = rig.NumCameras();
  const int num_frames = static_cast<int>(window.size());
  if (num_cameras < 2 || num_frames < 1) {
    *reason = "overlap start: needs two cameras";
    return std::nullopt;
  }
  const double max_px = options.sfm.max_reprojection_px;
  std::map<uint64_t, CrossPoint> points;
  std::vector<Rigid3d> poses(static_cast<size_t>(num_frames));
  TriangulateCross(rig, window.front(), poses[0], o, &points);
  for (int t = 1; t < num_frames; ++t) {
    Rigid3d predicted = poses[static_cast<size_t>(t - 1)];
    if (t >= 2) predicted = predicted * (poses[static_cast<size_t>(t - 2)].Inverse() * predicted);
    const std::vector<Sighting> sightings = SightingsOf(window[static_cast<size_t>(t)], num_cameras);
    const int inliers = PoseFrame(rig, sightings, points, max_px, &predicted);
    if (inliers < o.min_frame_inliers) {
      *reason =
          StrCat("overlap start: frame ", window[static_cast<size_t>(t)].frame_index, " fits ", inliers,
                 " observations < ", o.min_frame_inliers, " (", points.size(), " cross-camera landmarks)");
      return std::nullopt;
    }
    poses[static_cast<size_t>(t)] = predicted;
    TriangulateCross(rig, window[static_cast<size_t>(t)], predicted, o, &points);
  }

  // Step 3: the rig window BA over every observation.
  const std::vector<Rigid3d> cam_from_rig = rig.CamFromRig();
  std::map<uint64_t, Eigen::Vector3d> initial;
  for (const auto& [id, cp] : points) initial.emplace(id, cp.point_in_world);
  std::vector<RigWindowObservation> observations;
  for (int t = 0; t < num_frames; ++t) {
    for (const Sighting& s : SightingsOf(window[static_cast<size_t>(t)], num_cameras)) {
      if (initial.count(s.id) != 0) observations.push_back({t, s.camera, s.id, s.bearing});
    }
  }
  RigWindowBaOptions ba_options;
  ba_options.focal_px = options.sfm.focal_px;
  for (const Camera& camera : rig.cameras) ba_options.camera_focal_px.push_back(camera.MeanFocalLength());
  ba_options.huber_px = options.sfm.ba_huber_px;
  ba_options.max_reprojection_px = max_px;
  ba_options.max_iterations = std::max(1, options.max_rig_ba_iterations);
  const RigWindowBaResult ba = AdjustRigWindow(cam_from_rig, 0, poses, initial, observations, ba_options);
  if (!ba.ok) {
    *reason = StrCat("overlap start: ", ba.reason);
    return std::nullopt;
  }

  // Step 4: landmarks across cameras in the newest frame, and the scale's std.
  std::map<uint64_t, bool> in_newest;
  for (const Sighting& s : SightingsOf(window.back(), num_cameras)) in_newest[s.id] = true;
  const double rms = std::max(ba.rms_reprojection_px, kMinRmsPx);
  std::vector<double> information;  // 1 / relative variance per landmark
  for (const auto& [id, point] : ba.points) {
    if (in_newest.count(id) == 0) continue;
    const CrossPoint& cp = points.at(id);
    const double sigma = rms / (cp.focal * cp.angle);
    information.push_back(1.0 / (sigma * sigma));
  }
  const int count = static_cast<int>(information.size());
  if (count < o.min_points) {
    *reason =
        StrCat("overlap start: ", count, " cross-camera landmarks in the newest frame < ", o.min_points);
    return std::nullopt;
  }
  // At most kMaxIndependentPoints independent measurements of the mean information.
  double sum = 0.0;
  for (double i : information) sum += i;
  const double effective = std::min(count, kMaxIndependentPoints) * sum / count;
  const double sigma = 1.0 / std::sqrt(effective);
  if (!(sigma <= o.max_relative_scale_sigma)) {
    *reason =
        StrCat("overlap start: scale sigma ", FormatFixed(100.0 * sigma, 2), " % > ",
               FormatFixed(100.0 * o.max_relative_scale_sigma, 2), " % (", count, " cross-camera landmarks)");
    return std::nullopt;
  }

  InitializationResult result;
  for (int t = 0; t < num_frames; ++t) {
    result.frame_index.push_back(window[static_cast<size_t>(t)].frame_index);
    result.t_ns.push_back(window[static_cast<size_t>(t)].t_ns);
  }
  result.world_from_rig = ba.world_from_rig;
  std::map<int, int> per_camera;
  for (const auto& [id, point] : ba.points) {
    InitializationResult::Landmark lm;
    lm.id = id;
    lm.camera = points.at(id).camera;
    lm.point_in_world = point;
    result.landmarks.push_back(lm);
    ++per_camera[lm.camera];
  }
  result.anchor_frame_index = window.front().frame_index;
  result.principal_camera = per_camera.empty() ? 0 : per_camera.begin()->first;
  for (const auto& [camera, n] : per_camera) {
    if (n > per_camera.at(result.principal_camera)) result.principal_camera = camera;
  }
  // Used: every camera that observes a landmark in the result (metric by construction).
  result.camera_used.assign(static_cast<size_t>(num_cameras), false);
  result.camera_scales.assign(static_cast<size_t>(num_cameras), 0.0);
  for (const RigWindowObservation& obs : observations) {
    if (ba.points.count(obs.landmark) == 0) continue;
    result.camera_used[static_cast<size_t>(obs.camera)] = true;
    result.camera_scales[static_cast<size_t>(obs.camera)] = 1.0;
  }
  result.source = ScaleSource::kOverlapStart;
  result.relative_scale_sigma = sigma;
  result.cross_camera_matches = count;
  *reason = "initialised";
  return result;
}

}  // namespace mcvo
