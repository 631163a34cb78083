// Global rig bundle adjustment (refine/global_ba.h).
#include "mcvo/refine/global_ba.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <map>
#include <numeric>
#include <optional>
#include <set>
#include <utility>

#include <ceres/ceres.h>
#include <Eigen/Geometry>

#include "mcvo/backend/factors.h"
#include "mcvo/util/error.h"
#include "mcvo/util/option_checks.h"
#include "mcvo/util/strings.h"
#include "global_ba_costs.h"

namespace mcvo {
namespace {

using refine_internal::ExtrinsicPriorCost;
using refine_internal::LandmarkTieCost;
using refine_internal::RelativePoseCost;
using refine_internal::StraightScaleCost;

// Relative std of the scale gauge of a scale-free problem: tight, it only
// removes the null space.
constexpr double kScaleAnchorRelativeSigma = 1e-4;

struct Observation {
  int keyframe = 0;
  int index = 0;     // in the keyframe's observations
  int camera = 0;
  int landmark = 0;  // index into Problem's landmark arrays
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();
  bool active = true;
  bool in_solve = true;  // false: a long track's thinned keyframe (global_ba.h "Long tracks")
};

int FindRoot(std::vector<int>* parent, int i) {
  while ((*parent)[static_cast<size_t>(i)] != i) {
    (*parent)[static_cast<size_t>(i)] = (*parent)[static_cast<size_t>((*parent)[static_cast<size_t>(i)])];
    i = (*parent)[static_cast<size_t>(i)];
  }
  return i;
}

// The whole problem's state between solves: parameter storage (fixed
// addresses, in keyframe and landmark-id order, so the elimination order and
// every sum are the same on every run) and the observations.
class GlobalProblem {
 public:
  GlobalProblem(const Rig& rig, const SparseMap& map, bool scale_free, const GlobalBaOptions& options,
                const std::vector<GlobalBaPoseConstraint>& constraints, const std::vector<GlobalBaLandmarkTie>& ties)
      : options_(options),
        loss_scale_(options.loss_scale),
        constraints_(constraints),
        ties_(ties),
        scale_free_(scale_free),
        cam_from_rig_(rig.CamFromRig()),
        sqrt_information_(options.virtual_focal_px / options.reprojection_sigma_px),
        input_(map.keyframes) {
    const std::vector<MapKeyframe>& keyframes = map.keyframes;
    poses_.resize(keyframes.size());
    for (size_t k = 0; k < keyframes.size(); ++k) PoseToParams(keyframes[k].world_from_rig, poses_[k].data());
    extrinsics_.resize(cam_from_rig_.size());
    for (size_t c = 0; c < cam_from_rig_.size(); ++c) PoseToParams(cam_from_rig_[c], extrinsics_[c].data());
    for (const MapLandmark& landmark : map.landmarks) {
      if (!landmark_index_.emplace(landmark.id, static_cast<int>(landmark_ids_.size())).second) continue;
      landmark_ids_.push_back(landmark.id);
      const Eigen::Vector3d& p = landmark.position_world;
      points_.push_back({p.x(), p.y(), p.z()});
    }
    for (size_t k = 0; k < keyframes.size(); ++k) {
      for (size_t i = 0; i < keyframes[k].observations.size(); ++i) {
        const MapObservation& ob = keyframes[k].observations[i];
        if (ob.camera < 0 || ob.camera >= rig.NumCameras()) continue;
        const auto it = landmark_index_.find(ob.landmark_id);
        if (it == landmark_index_.end()) continue;
        const std::optional<Eigen::Vector3d> bearing = rig.cameras[static_cast<size_t>(ob.camera)].Unproject(ob.pixel);
        if (!bearing || !bearing->allFinite()) continue;
        Observation o;
        o.keyframe = static_cast<int>(k);
        o.index = static_cast<int>(i);
        o.camera = ob.camera;
        o.landmark = it->second;
        o.bearing = bearing->normalized();
        observations_.push_back(o);
      }
    }
    CountSharedLandmarks();
    ThinLongTracks();
  }

  // global_ba.h "Long tracks": a landmark seen in more than
  // thin_tracks_longer_than keyframes keeps its observations of every
  // thin_track_stride-th of them and of its last in the solves.
  void ThinLongTracks() {
    if (options_.thin_tracks_longer_than <= 0) return;
    std::vector<int> keyframes(points_.size(), 0), last(points_.size(), -1), rank(points_.size(), -1);
    for (const Observation& o : observations_) {  // in keyframe order
      const size_t i = static_cast<size_t>(o.landmark);
      keyframes[i] += last[i] != o.keyframe ? 1 : 0;
      last[i] = o.keyframe;
    }
    last.assign(points_.size(), -1);
    for (Observation& o : observations_) {
      const size_t i = static_cast<size_t>(o.landmark);
      rank[i] += last[i] != o.keyframe ? 1 : 0;
      last[i] = o.keyframe;
      if (keyframes[i] <= options_.thin_tracks_longer_than) continue;
      o.in_solve = rank[i] % options_.thin_track_stride == 0 || rank[i] == keyframes[i] - 1;
    }
  }

  // Per keyframe: landmarks seen by two or more of its cameras (overlapping
  // views), over the observations as loaded.
  void CountSharedLandmarks() {
    shared_landmarks_.assign(poses_.size(), 0);
    std::map<std::pair<int, int>, int> first_camera;  // (keyframe, landmark) -> camera, -1 once shared
    for (const Observation& o : observations_) {
      auto [it, inserted] = first_camera.emplace(std::make_pair(o.keyframe, o.landmark), o.camera);
      if (inserted || it->second < 0 || it->second == o.camera) continue;
      it->second = -1;
      ++shared_landmarks_[static_cast<size_t>(o.keyframe)];
    }
  }

  // Marks the landmarks with enough active observations and the keyframes
  // holding one; false when nothing is left to solve.
  bool SelectActive() {
    std::vector<int> count(points_.size(), 0);
    for (const Observation& o : observations_) count[static_cast<size_t>(o.landmark)] += o.active && o.in_solve;
    landmark_used_.assign(points_.size(), false);
    for (size_t i = 0; i < points_.size(); ++i) landmark_used_[i] = count[i] >= options_.min_observations;
    keyframe_used_.assign(poses_.size(), false);
    bool any = false;
    for (const Observation& o : observations_) {
      if (!Counts(o)) continue;
      keyframe_used_[static_cast<size_t>(o.keyframe)] = true;
      any = true;
    }
    return any;
  }

  bool Counts(const Observation& o) const {
    return o.active && o.in_solve && landmark_used_[static_cast<size_t>(o.landmark)];
  }

  // One Ceres solve over the active observations.
  ceres::Solver::Summary Solve(double function_tolerance, bool inner_iterations, int* components,
                               int* constraints_used) {
    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    std::unique_ptr<ceres::Manifold> manifold(NewPoseManifold());
    std::unique_ptr<ceres::LossFunction> loss = NewRobustLoss(options_.loss, loss_scale_);
    for (size_t k = 0; k < poses_.size(); ++k) {
      if (keyframe_used_[k]) problem.AddParameterBlock(poses_[k].data(), kPoseParamSize, manifold.get());
    }
    for (const Observation& o : observations_) {
      if (!Counts(o)) continue;
      double* pose = poses_[static_cast<size_t>(o.keyframe)].data();
      double* point = points_[static_cast<size_t>(o.landmark)].data();
      if (options_.refine_extrinsics) {
        problem.AddResidualBlock(NewWorldPointExtrinsicFactor(o.bearing, sqrt_information_), loss.get(), pose,
                                 extrinsics_[static_cast<size_t>(o.camera)].data(), point);
      } else {
        problem.AddResidualBlock(
            NewWorldPointFactor(o.bearing, cam_from_rig_[static_cast<size_t>(o.camera)], sqrt_information_),
            loss.get(), pose, point);
      }
    }
    if (options_.refine_extrinsics) AddExtrinsicPriors(&problem, manifold.get());
    std::vector<std::unique_ptr<ceres::LossFunction>> constraint_losses;
    *constraints_used = 0;
    for (const GlobalBaPoseConstraint& c : constraints_) {
      if (!ConstraintUsable(c)) continue;
      ++*constraints_used;
      constraint_losses.push_back(std::make_unique<ceres::CauchyLoss>(c.loss_scale));
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<RelativePoseCost, 6, kPoseParamSize, kPoseParamSize>(new RelativePoseCost(c)),
          constraint_losses.back().get(), poses_[static_cast<size_t>(c.from)].data(),
          poses_[static_cast<size_t>(c.to)].data());
    }
    AddLandmarkTies(&problem);
    *components = FixGauge(&problem);
    AddStraightScaleHold(&problem);

    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    // Schur elimination needs the eliminated points independent: one point
    // of each tie joins the poses' group.
    std::vector<bool> eliminated(points_.size(), true);
    for (const GlobalBaLandmarkTie& tie : ties_) {
      const auto pair = TieUsable(tie);
      if (pair && eliminated[static_cast<size_t>(pair->first)]) eliminated[static_cast<size_t>(pair->second)] = false;
    }
    // "Solves" in global_ba.h: with inner iterations, the eliminated points
    // (an independent set by construction) are their one group, given
    // explicitly: Ceres' automatic grouping walks a hash set of addresses.
    auto inner = std::make_shared<ceres::ParameterBlockOrdering>();
    for (size_t i = 0; i < points_.size(); ++i) {
      if (!landmark_used_[i] || !problem.HasParameterBlock(points_[i].data())) continue;
      ordering->AddElementToGroup(points_[i].data(), eliminated[i] ? 0 : 1);
      if (inner_iterations && eliminated[i]) inner->AddElementToGroup(points_[i].data(), 0);
    }
    for (size_t k = 0; k < poses_.size(); ++k) {
      if (keyframe_used_[k]) ordering->AddElementToGroup(poses_[k].data(), 1);
    }
    for (std::array<double, kPoseParamSize>& extrinsic : extrinsics_) {
      if (problem.HasParameterBlock(extrinsic.data())) ordering->AddElementToGroup(extrinsic.data(), 1);
    }
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
    solver_options.sparse_linear_algebra_library_type =
        ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) ? ceres::SUITE_SPARSE
                                                                               : ceres::EIGEN_SPARSE;
    solver_options.linear_solver_ordering = ordering;
    solver_options.use_inner_iterations = inner->NumElements() > 0;
    solver_options.inner_iteration_ordering = inner;
    solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    solver_options.max_num_iterations = options_.max_iterations;
    solver_options.function_tolerance = function_tolerance;
    solver_options.num_threads = 1;  // see global_ba.h: the Schur reduction's sums must not depend on threads
    solver_options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    return summary;
  }

  // Error (px at the virtual focal) of each counted observation; negative
  // for a point behind the camera.
  double Error(const Observation& o) const {
    const Rigid3d world_from_rig = PoseFromParams(poses_[static_cast<size_t>(o.keyframe)].data());
    const std::array<double, 3>& p = points_[static_cast<size_t>(o.landmark)];
    const Eigen::Vector3d point_cam =
        CamFromRig(o.camera) * (world_from_rig.Inverse() * Eigen::Vector3d(p[0], p[1], p[2]));
    const double norm = point_cam.norm();
    if (!(norm > 1e-12)) return -1.0;
    const Eigen::Vector3d u = point_cam / norm;
    if (u.dot(o.bearing) <= 0.0) return -1.0;
    return options_.reprojection_sigma_px * sqrt_information_ * (TangentBasis(o.bearing) * (u - o.bearing)).norm();
  }

  double RmsError(int* count) const {
    double sum = 0.0;
    *count = 0;
    for (const Observation& o : observations_) {
      if (!Counts(o)) continue;
      const double e = Error(o);
      sum += e < 0.0 ? 0.0 : e * e;
      ++*count;
    }
    return *count > 0 ? std::sqrt(sum / *count) : 0.0;
  }

  // global_ba.h "Robust loss": the knee of the next solve from the noise in
  // the counted observations' errors (px at the virtual focal).
  double MeasuredKneePx() const {
    std::vector<double> errors;
    for (const Observation& o : observations_) {
      if (!Counts(o)) continue;
      const double e = Error(o);
      if (e >= 0.0) errors.push_back(e);
    }
    const double first = options_.loss_scale * options_.reprojection_sigma_px;
    if (errors.empty()) return first;
    const size_t mid = errors.size() / 2;
    std::nth_element(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(mid), errors.end());
    const double sigma = errors[mid] / 1.1774;
    return std::clamp(options_.adaptive_loss_sigmas * sigma, std::min(options_.adaptive_loss_min_px, first), first);
  }
  double KneePx() const { return loss_scale_ * options_.reprojection_sigma_px; }
  void SetKneePx(double knee_px) { loss_scale_ = knee_px / options_.reprojection_sigma_px; }

  // Deactivates outliers and points behind the camera; returns how many.
  // Those of the solve, or (thinned_only) the long tracks' observations left
  // out of it, tested against the solved landmarks.
  int RemoveOutliers(bool thinned_only = false) {
    int removed = 0;
    for (Observation& o : observations_) {
      if (!o.active || !landmark_used_[static_cast<size_t>(o.landmark)] || o.in_solve == thinned_only) continue;
      const double e = Error(o);
      if (e < 0.0 || e > options_.outlier_threshold_px) {
        o.active = false;
        ++removed;
      }
    }
    return removed;
  }

  void Write(const SparseMap& input, GlobalBaResult* result) const {
    SparseMap& map = result->map;
    map = input;
    result->refined.assign(poses_.size(), false);
    std::vector<std::vector<bool>> removed(map.keyframes.size());
    for (size_t k = 0; k < map.keyframes.size(); ++k) removed[k].assign(map.keyframes[k].observations.size(), false);
    for (const Observation& o : observations_) {
      if (!o.active) removed[static_cast<size_t>(o.keyframe)][static_cast<size_t>(o.index)] = true;
    }
    std::set<int64_t> observed;
    for (size_t k = 0; k < map.keyframes.size(); ++k) {
      MapKeyframe& kf = map.keyframes[k];
      result->refined[k] = keyframe_used_[k];
      if (keyframe_used_[k]) kf.world_from_rig = PoseFromParams(poses_[k].data());
      std::vector<MapObservation> kept;
      for (size_t i = 0; i < kf.observations.size(); ++i) {
        if (removed[k][i]) continue;
        kept.push_back(kf.observations[i]);
        observed.insert(kf.observations[i].landmark_id);
      }
      kf.observations = std::move(kept);
    }
    std::vector<MapLandmark> landmarks;
    for (const MapLandmark& landmark : map.landmarks) {
      if (observed.count(landmark.id) == 0) continue;
      MapLandmark out = landmark;
      const size_t i = static_cast<size_t>(landmark_index_.at(landmark.id));
      if (landmark_used_[i]) out.position_world = Eigen::Vector3d(points_[i][0], points_[i][1], points_[i][2]);
      landmarks.push_back(out);
    }
    map.landmarks = std::move(landmarks);
    result->cam_from_rig.clear();
    result->extrinsic_rotation_change_deg.clear();
    result->extrinsic_translation_change_m.clear();
    for (size_t c = 0; c < extrinsics_.size(); ++c) {
      const Rigid3d refined = CamFromRig(static_cast<int>(c));
      result->cam_from_rig.push_back(refined);
      result->extrinsic_rotation_change_deg.push_back(refined.rotation.angularDistance(cam_from_rig_[c].rotation) *
                                                      180.0 / M_PI);
      result->extrinsic_translation_change_m.push_back(
          (refined.Inverse().translation - cam_from_rig_[c].Inverse().translation).norm());
    }
    result->keyframes_refined = static_cast<int>(std::count(keyframe_used_.begin(), keyframe_used_.end(), true));
    result->landmarks_refined = static_cast<int>(std::count(landmark_used_.begin(), landmark_used_.end(), true));
  }

  int straight_scale_residuals() const { return straight_scale_residuals_; }
  int ties_used() const { return ties_used_; }

 private:
  // global_ba.h "Scale on straights", over the used keyframes in order.
  void AddStraightScaleHold(ceres::Problem* problem) {
    straight_scale_residuals_ = 0;
    if (!(options_.straight_scale_sigma > 0.0)) return;
    std::vector<int> used;
    for (size_t k = 0; k < poses_.size(); ++k) {
      if (keyframe_used_[k]) used.push_back(static_cast<int>(k));
    }
    const int n = static_cast<int>(used.size());
    const int w = options_.straight_window_keyframes;
    const double max_rotation_rad = options_.straight_max_rotation_deg * M_PI / 180.0;
    constexpr double kMinIntervalM = 0.01;
    // Consecutive spans of w keyframes: (i - w, i) and (i, i + w).
    for (int i = w; i + w < n; i += w) {
      const size_t a = static_cast<size_t>(used[i - w]), b = static_cast<size_t>(used[i]),
                   c = static_cast<size_t>(used[i + w]);
      const Rigid3d &pa = input_[a].world_from_rig, &pb = input_[b].world_from_rig, &pc = input_[c].world_from_rig;
      if (input_[a].segment != input_[c].segment) continue;
      if (pa.rotation.angularDistance(pc.rotation) > max_rotation_rad) continue;
      // Overlapping views observe the scale through their baselines: no hold there.
      int shared = 0;
      for (int j = i - w; j <= i + w; ++j) shared += shared_landmarks_[static_cast<size_t>(used[static_cast<size_t>(j)])];
      if (shared >= options_.straight_overlap_min_landmarks * (2 * w + 1)) continue;
      const double ab = (pb.translation - pa.translation).norm();
      const double bc = (pc.translation - pb.translation).norm();
      if (!(ab >= kMinIntervalM && bc >= kMinIntervalM)) continue;
      const double sigma = options_.straight_scale_sigma * std::sqrt(0.5 * (ab + bc) / 100.0);
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<StraightScaleCost, 1, kPoseParamSize, kPoseParamSize,
                                                                kPoseParamSize>(new StraightScaleCost(ab, bc, sigma)),
                                nullptr, poses_[a].data(), poses_[b].data(), poses_[c].data());
      ++straight_scale_residuals_;
    }
  }

  // Camera c's cam_from_rig as it stands (the calibration unless refined).
  Rigid3d CamFromRig(int c) const {
    if (!options_.refine_extrinsics) return cam_from_rig_[static_cast<size_t>(c)];
    return PoseFromParams(extrinsics_[static_cast<size_t>(c)].data());
  }

  // global_ba.h "Extrinsics": the prior of every camera in the problem.
  void AddExtrinsicPriors(ceres::Problem* problem, ceres::Manifold* manifold) {
    const double sigma_rad = options_.extrinsic_rotation_sigma_deg * M_PI / 180.0;
    for (size_t c = 0; c < extrinsics_.size(); ++c) {
      double* extrinsic = extrinsics_[c].data();
      if (!problem->HasParameterBlock(extrinsic)) continue;  // no observation of this camera
      problem->SetManifold(extrinsic, manifold);
      if (c == 0) {  // the reference camera defines the rig frame
        problem->SetParameterBlockConstant(extrinsic);
        continue;
      }
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<ExtrinsicPriorCost, 6, kPoseParamSize>(
                                    new ExtrinsicPriorCost(cam_from_rig_[c], sigma_rad,
                                                           options_.extrinsic_translation_sigma_m)),
                                nullptr, extrinsic);
    }
  }

  // Index pair of a tie whose landmarks are both in the problem, distinct.
  std::optional<std::pair<int, int>> TieUsable(const GlobalBaLandmarkTie& tie) const {
    const auto a = landmark_index_.find(tie.landmark_a), b = landmark_index_.find(tie.landmark_b);
    if (a == landmark_index_.end() || b == landmark_index_.end() || a->second == b->second) return std::nullopt;
    if (!landmark_used_[static_cast<size_t>(a->second)] || !landmark_used_[static_cast<size_t>(b->second)]) {
      return std::nullopt;
    }
    return std::make_pair(a->second, b->second);
  }

  void AddLandmarkTies(ceres::Problem* problem) {
    ties_used_ = 0;
    tie_losses_.clear();
    for (const GlobalBaLandmarkTie& tie : ties_) {
      const auto pair = TieUsable(tie);
      if (!pair) continue;
      tie_losses_.push_back(std::make_unique<ceres::CauchyLoss>(tie.loss_scale));
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<LandmarkTieCost, 3, 3, 3>(
                                    new LandmarkTieCost(tie.sigma_m)),
                                tie_losses_.back().get(), points_[static_cast<size_t>(pair->first)].data(),
                                points_[static_cast<size_t>(pair->second)].data());
      ++ties_used_;
    }
  }

  // Both keyframes in the problem, distinct.
  bool ConstraintUsable(const GlobalBaPoseConstraint& c) const {
    const int n = static_cast<int>(poses_.size());
    return c.from >= 0 && c.to >= 0 && c.from < n && c.to < n && c.from != c.to &&
           keyframe_used_[static_cast<size_t>(c.from)] && keyframe_used_[static_cast<size_t>(c.to)];
  }

  // Holds each component's first keyframe fixed (and, scale-free, its
  // distance to the component's last keyframe); returns the number of
  // components.
  int FixGauge(ceres::Problem* problem) {
    std::vector<int> parent(poses_.size());
    std::iota(parent.begin(), parent.end(), 0);
    std::vector<int> first_observer(points_.size(), -1);
    for (const Observation& o : observations_) {
      if (!Counts(o)) continue;
      int& first = first_observer[static_cast<size_t>(o.landmark)];
      if (first < 0) {
        first = o.keyframe;
        continue;
      }
      const int a = FindRoot(&parent, first), b = FindRoot(&parent, o.keyframe);
      if (a != b) parent[static_cast<size_t>(std::max(a, b))] = std::min(a, b);  // the root is the first keyframe
    }
    for (const GlobalBaPoseConstraint& c : constraints_) {
      if (!ConstraintUsable(c)) continue;
      const int a = FindRoot(&parent, c.from), b = FindRoot(&parent, c.to);
      if (a != b) parent[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
    }
    for (const GlobalBaLandmarkTie& tie : ties_) {
      const auto pair = TieUsable(tie);
      if (!pair) continue;
      const int fa = first_observer[static_cast<size_t>(pair->first)];
      const int fb = first_observer[static_cast<size_t>(pair->second)];
      if (fa < 0 || fb < 0) continue;
      const int a = FindRoot(&parent, fa), b = FindRoot(&parent, fb);
      if (a != b) parent[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
    }
    std::map<int, int> last_of_component;
    int components = 0;
    for (size_t k = 0; k < poses_.size(); ++k) {
      if (!keyframe_used_[k]) continue;
      const int root = FindRoot(&parent, static_cast<int>(k));
      if (root == static_cast<int>(k)) {
        problem->SetParameterBlockConstant(poses_[k].data());
        ++components;
      }
      last_of_component[root] = static_cast<int>(k);
    }
    if (scale_free_) {
      for (const auto& [root, last] : last_of_component) {
        if (last == root) continue;
        const Eigen::Vector3d origin(poses_[static_cast<size_t>(root)][0], poses_[static_cast<size_t>(root)][1],
                                     poses_[static_cast<size_t>(root)][2]);
        const Eigen::Vector3d end(poses_[static_cast<size_t>(last)][0], poses_[static_cast<size_t>(last)][1],
                                  poses_[static_cast<size_t>(last)][2]);
        const double distance = (end - origin).norm();
        if (!(distance > 1e-9)) continue;
        problem->AddResidualBlock(NewDistanceAnchorCost(origin, distance, kScaleAnchorRelativeSigma * distance),
                                  nullptr, poses_[static_cast<size_t>(last)].data());
      }
    }
    return components;
  }

  const GlobalBaOptions& options_;
  double loss_scale_;  // of the next solve, in units of reprojection_sigma_px ("Robust loss")
  const std::vector<GlobalBaPoseConstraint>& constraints_;
  const std::vector<GlobalBaLandmarkTie>& ties_;
  std::vector<std::unique_ptr<ceres::LossFunction>> tie_losses_;  // of the current solve's ties
  int ties_used_ = 0;
  const bool scale_free_;
  const std::vector<Rigid3d> cam_from_rig_;
  const double sqrt_information_;
  std::vector<std::array<double, kPoseParamSize>> poses_;
  std::vector<std::array<double, kPoseParamSize>> extrinsics_;  // cam_from_rig per camera (refine_extrinsics)
  std::vector<std::array<double, 3>> points_;
  std::vector<int64_t> landmark_ids_;
  std::map<int64_t, int> landmark_index_;  // id -> index into points_ / landmark_ids_
  std::vector<Observation> observations_;
  std::vector<bool> landmark_used_, keyframe_used_;
  const std::vector<MapKeyframe>& input_;  // the map's keyframes as given (the straight-road scale hold)
  std::vector<int> shared_landmarks_;  // CountSharedLandmarks
  int straight_scale_residuals_ = 0;
};

}  // namespace

void GlobalBaOptions::Check() const {
  CheckAtLeast("/refine/max_iterations", max_iterations, 1);
  CheckAtLeast("/refine/outlier_rounds", outlier_rounds, 0);
  CheckPositive("/refine/first_solve_function_tolerance", first_solve_function_tolerance);
  CheckPositive("/refine/loss_scale", loss_scale);
  CheckAtLeast("/refine/adaptive_loss_sigmas", adaptive_loss_sigmas, 0.0);
  CheckPositive("/refine/adaptive_loss_min_px", adaptive_loss_min_px);
  CheckPositive("/refine/reprojection_sigma_px", reprojection_sigma_px);
  CheckPositive("/refine/virtual_focal_px", virtual_focal_px);
  CheckPositive("/refine/outlier_threshold_px", outlier_threshold_px);
  CheckAtLeast("/refine/min_observations", min_observations, 2);
  CheckPositive("/refine/function_tolerance", function_tolerance);
  CheckAtLeast("/refine/thin_tracks_longer_than", thin_tracks_longer_than, 0);
  CheckAtLeast("/refine/thin_track_stride", thin_track_stride, 1);
  CheckAtLeast("/refine/straight_scale_sigma", straight_scale_sigma, 0.0);
  CheckPositive("/refine/straight_max_rotation_deg", straight_max_rotation_deg);
  CheckAtLeast("/refine/straight_window_keyframes", straight_window_keyframes, 1);
  CheckAtLeast("/refine/straight_overlap_min_landmarks", straight_overlap_min_landmarks, 0);
  CheckPositive("/refine/extrinsic_rotation_sigma_deg", extrinsic_rotation_sigma_deg);
  CheckPositive("/refine/extrinsic_translation_sigma_m", extrinsic_translation_sigma_m);
  CheckAtLeast("/refine/cross_camera_link_sigma_px", cross_camera_link_sigma_px, 0.0);
}

GlobalBaResult RunGlobalBundleAdjustment(const Rig& rig, const SparseMap& map, bool scale_free,
                                         const GlobalBaOptions& options,
                                         const std::vector<GlobalBaPoseConstraint>& constraints,
                                         const std::vector<GlobalBaLandmarkTie>& ties) {
  for (const GlobalBaPoseConstraint& c : constraints) {
    MCVO_CHECK_MSG(c.rotation_sigma_rad > 0.0 && c.translation_sigma_m > 0.0 && c.loss_scale > 0.0,
                   "pose constraint sigmas and loss scale must be > 0");
  }
  for (const GlobalBaLandmarkTie& tie : ties) {
    MCVO_CHECK_MSG(tie.sigma_m > 0.0 && tie.loss_scale > 0.0, "landmark tie sigma and loss scale must be > 0");
  }
  const auto start = std::chrono::steady_clock::now();
  GlobalBaResult result;
  result.map = map;
  result.refined.assign(map.keyframes.size(), false);
  result.cam_from_rig = rig.CamFromRig();
  result.extrinsic_rotation_change_deg.assign(result.cam_from_rig.size(), 0.0);
  result.extrinsic_translation_change_m.assign(result.cam_from_rig.size(), 0.0);

  GlobalProblem problem(rig, map, scale_free, options, constraints, ties);
  if (!problem.SelectActive()) {
    result.message = "no landmark is observed twice";
    return result;
  }
  int count = 0;
  result.rms_error_px_before = problem.RmsError(&count);
  const bool adaptive = options.adaptive_loss_sigmas > 0.0;
  for (int round = 0; round <= options.outlier_rounds; ++round) {
    result.loss_knee_px.push_back(problem.KneePx());
    // global_ba.h "Solves": a solve that another follows only has to bring
    // the errors near their final size for the outlier test and the knee
    // measured from them; the last one converges fully.
    const bool short_solve =
        round < options.outlier_rounds && options.first_solve_function_tolerance > options.function_tolerance;
    const double tolerance = short_solve ? options.first_solve_function_tolerance : options.function_tolerance;
    const ceres::Solver::Summary summary =
        problem.Solve(tolerance, options.inner_iterations && !short_solve, &result.components, &result.constraints_used);
    if (round == 0) result.initial_cost = summary.initial_cost;
    result.final_cost = summary.final_cost;
    result.iterations += static_cast<int>(summary.iterations.size()) - 1;
    result.message = summary.message;
    result.straight_scale_residuals = problem.straight_scale_residuals();
    result.ties_used = problem.ties_used();
    ++result.solves;
    if (round == options.outlier_rounds) break;
    const int removed = problem.RemoveOutliers();
    result.observations_removed += removed;
    if (removed > 0 && !problem.SelectActive()) break;
    // global_ba.h "Robust loss": the next knee from this solve's residuals.
    const double knee = adaptive ? problem.MeasuredKneePx() : problem.KneePx();
    // The same problem again: nothing to gain, unless this solve was cut short.
    if (removed == 0 && !(knee < problem.KneePx()) && !short_solve) break;
    problem.SetKneePx(knee);
  }
  result.observations_removed += problem.RemoveOutliers(/*thinned_only=*/true);
  result.ran = true;
  result.rms_error_px_after = problem.RmsError(&result.observations_used);
  problem.Write(map, &result);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace mcvo
