#include "mcvo/backend/estimator.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <deque>
#include <map>
#include <optional>
#include <utility>

#include <ceres/ceres.h>
#include <Eigen/Geometry>

#include "mcvo/backend/factors.h"
#include "mcvo/backend/marginalization.h"
#include "mcvo/backend/rig_pnp.h"
#include "mcvo/backend/scale_filter.h"
#include "mcvo/initializer/rig_window_ba.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
// Smallest angle between two observation rays for a landmark to be
// triangulated: below it the depth is mostly noise.
constexpr double kMinTriangulationAngleRad = 0.5 * kDegToRad;
// Landmarks closer than this or farther than kMaxLandmarkDistanceM are not
// used (behind the camera, at infinity, or diverged).
constexpr double kMinLandmarkDistanceM = 0.1;
constexpr double kMaxLandmarkDistanceM = 1000.0;
// Scale correction: iterations of its rig BA; the window must travel at
// least this far; a camera's own ratio needs this many landmarks. (A
// measurement more than ScaleFilterOptions::max_innovation_sigmas = 4 from
// the current scale is an outlier.)
constexpr int kScaleCorrectionIterations = 20;
constexpr double kMinCorrectionTravelM = 2.0;
constexpr size_t kMinCameraDepthRatios = 10;
// Monocular scale gauge (estimator.h "Monocular"): the std of the anchored
// distance, relative to it, and the least distance worth anchoring.
constexpr double kScaleAnchorRelativeSigma = 1e-3;
constexpr double kMinScaleAnchorDistance = 1e-9;

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

struct Frame {
  int frame_index = 0;
  int64_t t_ns = 0;
  int segment = 0;
  bool keyframe = false;
  std::array<double, kPoseParamSize> pose{};  // world_from_rig
  RigFrameObservations obs;

  Rigid3d WorldFromRig() const { return PoseFromParams(pose.data()); }
  void SetWorldFromRig(const Rigid3d& world_from_rig) { PoseToParams(world_from_rig, pose.data()); }
};

struct Observation {
  Frame* frame = nullptr;
  int camera = 0;
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();
};

struct Landmark {
  int camera = 0;  // the camera whose feature it is
  Frame* anchor_frame = nullptr;
  int anchor_camera = 0;
  Eigen::Vector3d anchor_bearing = Eigen::Vector3d::UnitZ();
  double inverse_depth = 0.0;
  bool triangulated = false;
  std::vector<Observation> observations;  // the anchor's included
  // Position when the last keyframe that used it left the window: the map's
  // position when the landmark is no longer triangulated when it leaves (its
  // observations left the window one by one).
  std::optional<Eigen::Vector3d> map_position;
};

}  // namespace

struct Estimator::Impl {
  Impl(const Rig& rig_in, const InitializerOptions& init_options_in, const BackendOptions& options_in,
       int threads_in)
      : rig(rig_in),
        init_options(init_options_in),
        options(options_in),
        threads(std::max(1, threads_in)),
        initializer(rig_in, init_options_in, threads) {
    const int n = rig.NumCameras();
    extrinsics.resize(n);
    cam_from_rig.resize(n);
    for (int c = 0; c < n; ++c) {
      cam_from_rig[c] = rig.cameras[c].cam_from_rig;
      PoseToParams(cam_from_rig[c].Inverse(), extrinsics[c].data());
    }
    pose_manifold.reset(NewPoseManifold());
    frame_pool.resize(static_cast<size_t>(options.window_size) + 2);
    slot_used.assign(frame_pool.size(), false);
    sqrt_information = options.virtual_focal_px / options.reprojection_sigma_px;
    ScaleFilterOptions filter_options;
    filter_options.drift_per_100m = options.scale_drift_per_100m;
    filter_options.min_change = options.scale_correction_min_change;
    scale_filter = ScaleFilter(filter_options);
  }

  const Rig rig;
  const bool monocular = rig.NumCameras() == 1;  // estimator.h "Monocular"
  const InitializerOptions init_options;
  const BackendOptions options;
  const int threads;
  Initializer initializer;
  std::unique_ptr<ceres::Manifold> pose_manifold;
  double sqrt_information = 1.0;

  std::vector<std::array<double, kPoseParamSize>> extrinsics;  // rig_from_cam parameter blocks
  std::vector<Rigid3d> cam_from_rig;

  EstimatorState state = EstimatorState::kInitializing;
  int segment = 0;
  std::deque<RigFrameObservations> init_buffer;  // recent frames while initialising
  // Frames live in a fixed pool allocated once (window_size + 2 slots, the
  // most the window ever holds at once), so their pose blocks have stable
  // addresses whose order depends only on the slot: see BuildProblem.
  std::vector<Frame> frame_pool;
  std::vector<bool> slot_used;
  std::deque<Frame*> window;               // keyframes, then possibly one non-keyframe
  std::map<uint64_t, Landmark> landmarks;  // by feature id (ordered: deterministic)
  std::unique_ptr<MarginalizationPrior> prior;
  int solves_since_correction = 0;
  // Relative variance of the current scale (log scale) and where it was last
  // grown (see GrowScaleVariance).
  ScaleFilter scale_filter;  // the scale's uncertainty (scale_filter.h)

  // Last two poses (constant-velocity prediction; placing a new segment).
  std::optional<Rigid3d> last_pose, previous_pose;

  std::vector<KeyframeEstimate> finished_keyframes;
  std::vector<MapLandmark> finished_landmarks;
  std::vector<ScaleLogEntry> scale_log;

  // ---------------------------------------------------------------- helpers

  Frame* AcquireFrame() {
    for (size_t k = 0; k < frame_pool.size(); ++k) {
      if (slot_used[k]) continue;
      slot_used[k] = true;
      frame_pool[k] = Frame();
      return &frame_pool[k];
    }
    MCVO_CHECK_MSG(false, "frame pool of ", frame_pool.size(), " slots exhausted");
    return nullptr;
  }
  void ReleaseFrame(Frame* frame) {
    const size_t k = static_cast<size_t>(frame - frame_pool.data());
    MCVO_CHECK(k < frame_pool.size() && slot_used[k]);
    slot_used[k] = false;
    frame_pool[k].obs = RigFrameObservations();
  }
  void PopFront() {
    ReleaseFrame(window.front());
    window.pop_front();
  }
  void PopBack() {
    ReleaseFrame(window.back());
    window.pop_back();
  }
  void ClearWindow() {
    while (!window.empty()) PopFront();
  }

  // A keyframe leaving the estimator, with its observations of the
  // landmarks the BA uses.
  KeyframeEstimate FinishedKeyframe(const Frame* frame) {
    KeyframeEstimate out{frame->frame_index, frame->t_ns, frame->segment, frame->WorldFromRig(), {}, {}};
    for (int c = 0; c < static_cast<int>(frame->obs.cameras.size()); ++c) {
      for (const FeatureObservation& f : frame->obs.cameras[c]) {
        auto it = landmarks.find(f.id);
        if (it == landmarks.end() || !UsableInBa(it->second)) continue;
        const bool observed =
            std::any_of(it->second.observations.begin(), it->second.observations.end(),
                        [&](const Observation& ob) { return ob.frame == frame && ob.camera == c; });
        if (!observed) continue;
        out.observations.push_back({c, static_cast<int64_t>(f.id), f.pixel});
        out.observation_points.push_back(LandmarkInWorld(it->second));
        it->second.map_position = out.observation_points.back();
      }
    }
    return out;
  }

  // Every triangulated landmark leaves (new segment, end of run).
  void FinishAllLandmarks() {
    for (const auto& [id, lm] : landmarks) {
      if (lm.triangulated) {
        finished_landmarks.push_back({static_cast<int64_t>(id), LandmarkInWorld(lm)});
      } else if (lm.map_position) {
        finished_landmarks.push_back({static_cast<int64_t>(id), *lm.map_position});
      }
    }
  }

  Rigid3d WorldFromCam(const Frame& frame, int camera) const {
    return frame.WorldFromRig() * cam_from_rig[camera].Inverse();
  }

  Eigen::Vector3d LandmarkInWorld(const Landmark& lm) const {
    return WorldFromCam(*lm.anchor_frame, lm.anchor_camera) * (lm.anchor_bearing / lm.inverse_depth);
  }

  double ObservationErrorPx(const Landmark& lm, const Observation& ob) const {
    const Eigen::Vector2d r =
        ReprojectionResidual(lm.anchor_frame->WorldFromRig(), ob.frame->WorldFromRig(),
                             cam_from_rig[lm.anchor_camera].Inverse(), cam_from_rig[ob.camera].Inverse(),
                             lm.anchor_bearing, lm.inverse_depth, ob.bearing, options.virtual_focal_px);
    return r.norm();
  }

  bool HasObservationIn(const Landmark& lm, const Frame* frame) const {
    for (const Observation& ob : lm.observations) {
      if (ob.frame == frame) return true;
    }
    return false;
  }

  // Midpoint triangulation over all observation rays; sets the inverse
  // depth along the anchor bearing when the rays are wide enough apart, the
  // point is in front of the anchor and every observation fits.
  bool Triangulate(Landmark* lm) const {
    if (lm->observations.size() < 2) return false;
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector3d> directions;
    std::vector<Eigen::Vector3d> centres;
    for (const Observation& ob : lm->observations) {
      const Rigid3d world_from_cam = WorldFromCam(*ob.frame, ob.camera);
      const Eigen::Vector3d d = (world_from_cam.rotation * ob.bearing).normalized();
      const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - d * d.transpose();
      a += p;
      b += p * world_from_cam.translation;
      directions.push_back(d);
      centres.push_back(world_from_cam.translation);
    }
    double max_angle = 0.0;
    for (size_t i = 0; i < directions.size(); ++i) {
      for (size_t j = i + 1; j < directions.size(); ++j) {
        if ((centres[i] - centres[j]).norm() < 1e-9) continue;  // same centre: no baseline
        max_angle = std::max(max_angle, std::acos(std::clamp(directions[i].dot(directions[j]), -1.0, 1.0)));
      }
    }
    if (max_angle < kMinTriangulationAngleRad) return false;
    Eigen::LDLT<Eigen::Matrix3d> ldlt(a);
    if (ldlt.info() != Eigen::Success) return false;
    const Eigen::Vector3d point = ldlt.solve(b);
    if (!point.allFinite()) return false;
    const Rigid3d anchor_from_world = WorldFromCam(*lm->anchor_frame, lm->anchor_camera).Inverse();
    const double depth = (anchor_from_world * point).dot(lm->anchor_bearing);
    if (!(depth > kMinLandmarkDistanceM && depth < kMaxLandmarkDistanceM)) return false;
    Landmark candidate = *lm;
    candidate.inverse_depth = 1.0 / depth;
    for (const Observation& ob : candidate.observations) {
      if (!(ObservationErrorPx(candidate, ob) <= options.outlier_threshold_px)) return false;
    }
    lm->inverse_depth = candidate.inverse_depth;
    lm->triangulated = true;
    return true;
  }

  bool UsableInBa(const Landmark& lm) const {
    return lm.triangulated && static_cast<int>(lm.observations.size()) >= options.min_observations &&
           lm.inverse_depth > 1.0 / kMaxLandmarkDistanceM && lm.inverse_depth < 1.0 / kMinLandmarkDistanceM;
  }

  // Observations of the frame's features (own camera and cross-camera) of
  // landmarks that exist, as (landmark id, observation).
  std::vector<std::pair<uint64_t, Observation>> FrameObservations(Frame* frame) const {
    std::vector<std::pair<uint64_t, Observation>> out;
    for (int c = 0; c < static_cast<int>(frame->obs.cameras.size()); ++c) {
      for (const FeatureObservation& f : frame->obs.cameras[c]) out.push_back({f.id, {frame, c, f.bearing}});
    }
    for (const CrossCameraObservation& x : frame->obs.cross_camera) {
      out.push_back({x.id, {frame, x.camera_b, x.bearing_b}});
    }
    return out;
  }

  // New landmarks for the features of a keyframe that have none, anchored there.
  void CreateLandmarks(Frame* frame) {
    for (int c = 0; c < static_cast<int>(frame->obs.cameras.size()); ++c) {
      for (const FeatureObservation& f : frame->obs.cameras[c]) {
        if (landmarks.count(f.id) != 0) continue;
        Landmark lm;
        lm.camera = c;
        lm.anchor_frame = frame;
        lm.anchor_camera = c;
        lm.anchor_bearing = f.bearing.normalized();
        lm.inverse_depth = 1.0 / options.init_depth_m;
        lm.observations.push_back({frame, c, lm.anchor_bearing});
        landmarks.emplace(f.id, std::move(lm));
      }
    }
    for (const CrossCameraObservation& x : frame->obs.cross_camera) {
      auto it = landmarks.find(x.id);
      if (it == landmarks.end() || it->second.anchor_frame != frame) continue;
      if (HasCrossObservation(it->second, frame, x.camera_b)) continue;
      it->second.observations.push_back({frame, x.camera_b, x.bearing_b.normalized()});
    }
  }

  static bool HasCrossObservation(const Landmark& lm, const Frame* frame, int camera) {
    for (const Observation& ob : lm.observations) {
      if (ob.frame == frame && ob.camera == camera) return true;
    }
    return false;
  }

  void TriangulatePending() {
    for (auto& [id, lm] : landmarks) {
      if (!lm.triangulated) Triangulate(&lm);
    }
  }

  // Removes every observation in `frame`; landmarks anchored there are
  // re-anchored in their earliest remaining observation, or deleted.
  void RemoveFrameObservations(const Frame* frame) {
    for (auto it = landmarks.begin(); it != landmarks.end();) {
      Landmark& lm = it->second;
      const bool anchored_here = lm.anchor_frame == frame;
      std::optional<Eigen::Vector3d> point;
      if (anchored_here && lm.triangulated) point = LandmarkInWorld(lm);
      lm.observations.erase(std::remove_if(lm.observations.begin(), lm.observations.end(),
                                           [&](const Observation& ob) { return ob.frame == frame; }),
                            lm.observations.end());
      if (lm.observations.empty()) {
        if (point) {
          finished_landmarks.push_back({static_cast<int64_t>(it->first), *point});
        } else if (lm.map_position) {
          finished_landmarks.push_back({static_cast<int64_t>(it->first), *lm.map_position});
        }
        it = landmarks.erase(it);
        continue;
      }
      if (anchored_here) {
        // Earliest remaining observation: observations are appended in frame order.
        const Observation& first = lm.observations.front();
        lm.anchor_frame = first.frame;
        lm.anchor_camera = first.camera;
        lm.anchor_bearing = first.bearing;
        lm.triangulated = false;
        if (point) {
          const double depth =
              (WorldFromCam(*first.frame, first.camera).Inverse() * *point).dot(first.bearing);
          if (depth > kMinLandmarkDistanceM && depth < kMaxLandmarkDistanceM) {
            lm.inverse_depth = 1.0 / depth;
            lm.triangulated = true;
          }
        }
      }
      ++it;
    }
  }

  // ---------------------------------------------------------------- BA

  struct Problem {
    std::vector<std::unique_ptr<ceres::CostFunction>> costs;
    std::unique_ptr<ceres::LossFunction> loss;
    struct Block {
      ceres::CostFunction* cost;
      std::vector<double*> params;
      uint64_t landmark;  // 0: prior
    };
    std::vector<Block> blocks;
  };

  std::unique_ptr<ceres::LossFunction> MakeLoss() const {
    switch (options.loss) {
      case LossType::kHuber:
        return std::make_unique<ceres::HuberLoss>(options.loss_scale);
      case LossType::kCauchy:
        return std::make_unique<ceres::CauchyLoss>(options.loss_scale);
      case LossType::kTrivial:
        return nullptr;
    }
    return nullptr;
  }

  // Residual blocks of one landmark's observations (the anchor excluded).
  // inv: the landmark's inverse depth parameter block (its own member, or a
  // slot of the solve's contiguous buffer, see SolveWindow).
  void AddLandmarkBlocks(uint64_t id, Landmark* lm, double* inv, Problem* problem) {
    double* anchor_pose = lm->anchor_frame->pose.data();
    double* anchor_ext = extrinsics[lm->anchor_camera].data();
    for (const Observation& ob : lm->observations) {
      const bool same_frame = ob.frame == lm->anchor_frame;
      const bool same_camera = ob.camera == lm->anchor_camera;
      if (same_frame && same_camera) continue;
      ceres::CostFunction* cost = nullptr;
      std::vector<double*> params;
      if (!options.refine_extrinsics) {
        // Constant extrinsics (the values of the extrinsic blocks, which are
        // then in no residual block; Ceres drops them from the solve).
        const Rigid3d rig_from_cam_anchor = cam_from_rig[lm->anchor_camera].Inverse();
        const Rigid3d rig_from_cam_obs = cam_from_rig[ob.camera].Inverse();
        if (same_frame) {
          cost = NewReprojectionFactorSameFrameConstExtrinsics(
              lm->anchor_bearing, ob.bearing, rig_from_cam_anchor, rig_from_cam_obs, sqrt_information);
          params = {inv};
        } else if (same_camera) {
          cost = NewReprojectionFactorSameCameraConstExtrinsics(lm->anchor_bearing, ob.bearing,
                                                                rig_from_cam_anchor, sqrt_information);
          params = {anchor_pose, ob.frame->pose.data(), inv};
        } else {
          cost = NewReprojectionFactorOtherCameraConstExtrinsics(
              lm->anchor_bearing, ob.bearing, rig_from_cam_anchor, rig_from_cam_obs, sqrt_information);
          params = {anchor_pose, ob.frame->pose.data(), inv};
        }
      } else if (same_frame) {
        cost = NewReprojectionFactorSameFrame(lm->anchor_bearing, ob.bearing, sqrt_information);
        params = {anchor_ext, extrinsics[ob.camera].data(), inv};
      } else if (same_camera) {
        cost = NewReprojectionFactorSameCamera(lm->anchor_bearing, ob.bearing, sqrt_information);
        params = {anchor_pose, ob.frame->pose.data(), anchor_ext, inv};
      } else {
        cost = NewReprojectionFactorOtherCamera(lm->anchor_bearing, ob.bearing, sqrt_information);
        params = {anchor_pose, ob.frame->pose.data(), anchor_ext, extrinsics[ob.camera].data(), inv};
      }
      problem->costs.emplace_back(cost);
      problem->blocks.push_back({cost, std::move(params), id});
    }
  }

  // The inverse depths of the usable landmarks are copied into *depths (in
  // id order, reserved so it never reallocates) and optimised there: Ceres
  // orders the blocks of an elimination group by address, so contiguous
  // storage in id order makes the elimination order, and with it every
  // floating-point sum, independent of where the heap put the landmarks.
  Problem BuildProblem(std::vector<double>* depths, std::vector<Landmark*>* owners) {
    Problem problem;
    problem.loss = MakeLoss();
    depths->clear();
    owners->clear();
    depths->reserve(landmarks.size());
    for (auto& [id, lm] : landmarks) {
      if (!UsableInBa(lm)) continue;
      depths->push_back(lm.inverse_depth);
      owners->push_back(&lm);
      AddLandmarkBlocks(id, &lm, &depths->back(), &problem);
    }
    if (prior) problem.blocks.push_back({prior.get(), prior->kept_blocks(), 0});
    return problem;
  }

  // Monocular gauge: the keyframe (not the oldest, not the newest frame
  // unless nothing else is there) farthest from the oldest keyframe; null
  // when every frame is where the oldest is (pure rotation).
  Frame* ScaleAnchorFrame() const {
    if (window.size() < 2) return nullptr;
    const Eigen::Vector3d origin = window.front()->WorldFromRig().translation;
    Frame* best = nullptr;
    double best_distance = 0.0;
    const size_t last = window.size() > 2 ? window.size() - 1 : window.size();
    for (size_t k = 1; k < last; ++k) {
      const double d = (window[k]->WorldFromRig().translation - origin).norm();
      if (d > best_distance) {
        best_distance = d;
        best = window[k];
      }
    }
    return best_distance > kMinScaleAnchorDistance ? best : nullptr;
  }

  bool IsExtrinsicConstant(int camera) const { return !options.refine_extrinsics || camera == 0; }

  void SolveWindow(FrameEstimate* estimate) {
    std::vector<double> depths;
    std::vector<Landmark*> owners;
    Problem problem = BuildProblem(&depths, &owners);
    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem ceres_problem(problem_options);
    for (auto& frame : window)
      ceres_problem.AddParameterBlock(frame->pose.data(), kPoseParamSize, pose_manifold.get());
    for (int c = 0; c < rig.NumCameras(); ++c) {
      ceres_problem.AddParameterBlock(extrinsics[c].data(), kPoseParamSize, pose_manifold.get());
    }
    for (const Problem::Block& block : problem.blocks) {
      ceres_problem.AddResidualBlock(block.cost, block.landmark == 0 ? nullptr : problem.loss.get(),
                                     block.params);
    }
    // Gauge: the oldest keyframe is held fixed (the prior carries what was learnt before it).
    ceres_problem.SetParameterBlockConstant(window.front()->pose.data());
    // Monocular: the scale gauge too (estimator.h "Monocular").
    std::unique_ptr<ceres::CostFunction> scale_anchor;
    if (monocular) {
      Frame* reference = ScaleAnchorFrame();
      if (reference != nullptr) {
        const Eigen::Vector3d origin = window.front()->WorldFromRig().translation;
        const double distance = (reference->WorldFromRig().translation - origin).norm();
        scale_anchor.reset(NewDistanceAnchorCost(origin, distance, kScaleAnchorRelativeSigma * distance));
        ceres_problem.AddResidualBlock(scale_anchor.get(), nullptr, reference->pose.data());
      }
    }
    for (int c = 0; c < rig.NumCameras(); ++c) {
      if (IsExtrinsicConstant(c)) ceres_problem.SetParameterBlockConstant(extrinsics[c].data());
    }
    // Landmarks first in the elimination order (Schur complement on the poses).
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (double& depth : depths) {
      if (ceres_problem.HasParameterBlock(&depth)) ordering->AddElementToGroup(&depth, 0);
    }
    for (auto& frame : window) ordering->AddElementToGroup(frame->pose.data(), 1);
    for (int c = 0; c < rig.NumCameras(); ++c) ordering->AddElementToGroup(extrinsics[c].data(), 1);

    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_SCHUR;
    solver_options.linear_solver_ordering = ordering;
    solver_options.trust_region_strategy_type =
        options.solver == SolverType::kDogleg ? ceres::DOGLEG : ceres::LEVENBERG_MARQUARDT;
    solver_options.max_num_iterations = options.max_iterations;
    if (options.max_solver_time_s > 0.0)
      solver_options.max_solver_time_in_seconds = options.max_solver_time_s;
    solver_options.num_threads = 1;  // Schur reductions in parallel change summation order
    solver_options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    if (problem.blocks.empty()) return;
    ceres::Solve(solver_options, &ceres_problem, &summary);
    for (size_t k = 0; k < owners.size(); ++k) owners[k]->inverse_depth = depths[k];
    estimate->ba_iterations = static_cast<int>(summary.iterations.size()) - 1;
    estimate->ba_initial_cost = summary.initial_cost;
    estimate->ba_final_cost = summary.final_cost;
    ++solves_since_correction;
  }

  // Observations whose error exceeds the threshold are removed; landmarks
  // that end up out of range become untriangulated.
  void RemoveOutliers() {
    for (auto it = landmarks.begin(); it != landmarks.end();) {
      Landmark& lm = it->second;
      if (!lm.triangulated) {
        ++it;
        continue;
      }
      if (!(lm.inverse_depth > 1.0 / kMaxLandmarkDistanceM &&
            lm.inverse_depth < 1.0 / kMinLandmarkDistanceM)) {
        lm.triangulated = false;
        lm.inverse_depth = 1.0 / options.init_depth_m;
        ++it;
        continue;
      }
      // The anchor observation defines the landmark and always stays.
      std::vector<Observation> kept;
      for (const Observation& ob : lm.observations) {
        const bool is_anchor = ob.frame == lm.anchor_frame && ob.camera == lm.anchor_camera;
        if (is_anchor || ObservationErrorPx(lm, ob) <= options.outlier_threshold_px) kept.push_back(ob);
      }
      lm.observations = std::move(kept);
      if (lm.observations.size() < 2) lm.triangulated = false;
      ++it;
    }
  }

  // ---------------------------------------------------------------- marginalisation

  void MarginalizeOldest(FrameEstimate* estimate) {
    const auto start = std::chrono::steady_clock::now();
    Frame* oldest = window.front();
    Problem problem;
    problem.loss = MakeLoss();
    std::vector<double*> drop;
    for (auto& [id, lm] : landmarks) {
      if (lm.anchor_frame != oldest || !UsableInBa(lm)) continue;
      const size_t before = problem.blocks.size();
      AddLandmarkBlocks(id, &lm, &lm.inverse_depth, &problem);
      if (problem.blocks.size() > before) drop.push_back(&lm.inverse_depth);
    }
    Marginalizer marginalizer;
    for (auto& frame : window) marginalizer.SetManifold(frame->pose.data(), pose_manifold.get());
    for (int c = 0; c < rig.NumCameras(); ++c) {
      marginalizer.SetManifold(extrinsics[c].data(), pose_manifold.get());
      if (IsExtrinsicConstant(c)) marginalizer.SetConstant(extrinsics[c].data());
    }
    // The oldest pose is the gauge: constant, so conditioning on it turns
    // the relative information of its observations into information on the
    // kept poses.
    marginalizer.SetConstant(oldest->pose.data());
    for (const Problem::Block& block : problem.blocks) {
      marginalizer.AddResidualBlock(block.cost, problem.loss.get(), block.params);
    }
    if (prior) marginalizer.AddResidualBlock(prior.get(), nullptr, prior->kept_blocks());
    std::unique_ptr<MarginalizationPrior> next_prior;
    if (!drop.empty() || prior) next_prior = marginalizer.Marginalize(drop);
    prior = std::move(next_prior);

    finished_keyframes.push_back(FinishedKeyframe(oldest));
    RemoveFrameObservations(oldest);
    PopFront();
    estimate->seconds_marginalization += Seconds(start);
  }

  // ---------------------------------------------------------------- keyframes

  bool IsKeyframe(const Frame& newest) const {
    const Frame* last_keyframe = nullptr;
    for (auto it = window.rbegin(); it != window.rend(); ++it) {
      if ((*it)->keyframe && *it != &newest) {
        last_keyframe = *it;
        break;
      }
    }
    if (last_keyframe == nullptr) return true;
    // Tracked landmarks per camera.
    for (int c = 0; c < static_cast<int>(newest.obs.cameras.size()); ++c) {
      const auto& features = newest.obs.cameras[c];
      if (static_cast<int>(features.size()) < options.keyframe_min_tracked) continue;
      int tracked = 0;
      for (const FeatureObservation& f : features) tracked += landmarks.count(f.id) != 0 ? 1 : 0;
      if (tracked < options.keyframe_min_tracked) return true;
    }
    // Rotation-compensated parallax against the last keyframe.
    double sum = 0.0;
    int count = 0;
    for (int c = 0; c < static_cast<int>(newest.obs.cameras.size()); ++c) {
      const Eigen::Quaterniond new_from_kf =
          (WorldFromCam(newest, c).rotation.conjugate() * WorldFromCam(*last_keyframe, c).rotation);
      for (const FeatureObservation& f : newest.obs.cameras[c]) {
        auto it = landmarks.find(f.id);
        if (it == landmarks.end()) continue;
        for (const Observation& ob : it->second.observations) {
          if (ob.frame != last_keyframe || ob.camera != c) continue;
          const Eigen::Vector3d rotated = new_from_kf * ob.bearing;
          sum += std::acos(std::clamp(rotated.dot(f.bearing.normalized()), -1.0, 1.0));
          ++count;
        }
      }
    }
    if (count == 0) return true;
    return sum / count * options.virtual_focal_px >= options.keyframe_parallax_px;
  }

  // ---------------------------------------------------------------- scale correction

  // Largest rotation between the oldest keyframe of the window and any later frame.
  double WindowRotationDeg() const {
    double best = 0.0;
    const Eigen::Quaterniond first = window.front()->WorldFromRig().rotation;
    for (const Frame* frame : window) {
      best = std::max(best, first.angularDistance(frame->WorldFromRig().rotation));
    }
    return best / kDegToRad;
  }

  void ScaleCorrection(const Frame& newest, FrameEstimate* estimate) {
    const auto start = std::chrono::steady_clock::now();
    ScaleLogEntry entry;
    entry.frame_index = newest.frame_index;
    entry.t_ns = newest.t_ns;
    entry.segment = segment;
    entry.event = "correction";
    const int n = rig.NumCameras();
    entry.camera_scales.assign(n, 1.0);
    if (last_pose) scale_filter.Travel(last_pose->translation);
    auto log = [&](std::string note) {
      entry.note = std::move(note);
      entry.scale_sigma = scale_filter.sigma();
      scale_log.push_back(std::move(entry));
      estimate->seconds_scale += Seconds(start);
    };

    // The window (keyframes and the newest frame), its landmarks in world
    // coordinates, and their observations.
    std::vector<const Frame*> frames(window.begin(), window.end());
    std::map<const Frame*, int> frame_slot;
    std::vector<Rigid3d> poses;
    for (size_t t = 0; t < frames.size(); ++t) {
      frame_slot[frames[t]] = static_cast<int>(t);
      poses.push_back(frames[t]->WorldFromRig());
    }
    std::map<uint64_t, Eigen::Vector3d> points;
    std::vector<RigWindowObservation> observations;
    for (const auto& [id, lm] : landmarks) {
      if (!UsableInBa(lm)) continue;
      points[id] = LandmarkInWorld(lm);
      for (const Observation& ob : lm.observations) {
        observations.push_back({frame_slot.at(ob.frame), ob.camera, id, ob.bearing});
      }
    }
    RigWindowBaOptions ba_options;
    ba_options.focal_px = options.virtual_focal_px;
    for (const Camera& camera : rig.cameras) ba_options.camera_focal_px.push_back(camera.MeanFocalLength());
    ba_options.max_reprojection_px = options.outlier_threshold_px;
    ba_options.max_iterations = kScaleCorrectionIterations;
    const RigWindowBaResult ba = AdjustRigWindow(cam_from_rig, 0, poses, points, observations, ba_options);
    if (!ba.ok) return log(StrCat("not applied: rig BA failed: ", ba.reason));
    const double current_travel = (poses.back().translation - poses.front().translation).norm();
    entry.rms_reprojection_px = ba.rms_reprojection_px;
    if (!(current_travel > kMinCorrectionTravelM)) {
      return log(StrCat("not applied: window travel ", FormatFixed(current_travel, 2), " m < ",
                        FormatFixed(kMinCorrectionTravelM, 2), " m"));
    }
    const double ratio = ba.travel_m / current_travel;
    const double sigma = options.scale_correction_sigma_factor * ba.travel_relative_sigma;
    entry.measured_ratio = ratio;
    entry.measured_sigma = sigma;
    if (!(std::isfinite(ratio) && ratio > 0.0 && std::isfinite(sigma))) {
      return log("not applied: non-finite rig BA travel");
    }
    if (sigma > options.scale_correction_max_sigma) {
      return log(StrCat("not applied: measurement sigma ", FormatFixed(100.0 * sigma, 2), " % > ",
                        FormatFixed(100.0 * options.scale_correction_max_sigma, 2), " %"));
    }
    // A measurement: this correction is done (applied or not); until then
    // the next solves try again while the window turns.
    solves_since_correction = 0;
    const ScaleFilter::Update update = scale_filter.Measure(ratio, sigma);
    if (update.outcome == ScaleFilter::Outcome::kOutlier) {
      return log(StrCat("not applied: ratio ", FormatFixed(ratio, 4), " is ",
                        FormatFixed(update.innovation_sigmas, 1), " sigma from the current scale (outlier)"));
    }
    const double gain = update.gain;
    const double k = update.factor;
    entry.gain = gain;
    if (update.outcome == ScaleFilter::Outcome::kBelowMinChange) {
      return log(StrCat("not applied: fused change ", FormatFixed(100.0 * (k - 1.0), 3),
                        " % below scale_correction_min_change"));
    }
    // Per camera: the median change of its landmarks' depths from their
    // anchor camera in the rig BA, fused with the same gain.
    std::vector<std::vector<double>> depth_ratios(n);
    for (const auto& [id, lm] : landmarks) {
      auto refined = ba.points.find(id);
      if (!UsableInBa(lm) || refined == ba.points.end()) continue;
      const Rigid3d anchor = WorldFromCam(*lm.anchor_frame, lm.anchor_camera);
      // The anchor frame's refined pose: the BA moved it too.
      const Rigid3d refined_anchor =
          ba.world_from_rig[frame_slot.at(lm.anchor_frame)] * cam_from_rig[lm.anchor_camera].Inverse();
      const double before = (anchor.Inverse() * LandmarkInWorld(lm)).norm();
      const double after = (refined_anchor.Inverse() * refined->second).norm();
      if (before > 0.0 && after > 0.0) depth_ratios[lm.camera].push_back(after / before);
    }
    std::vector<double> camera_k(n, k);
    for (int c = 0; c < n; ++c) {
      std::vector<double>& r = depth_ratios[c];
      if (r.size() < kMinCameraDepthRatios) continue;
      std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
      const double median = r[r.size() / 2];
      camera_k[c] = std::exp(gain * std::log(median));
    }
    // Apply: positions about the fixed keyframe, the prior's linearisation
    // positions likewise, the last poses (constant-velocity prediction), and
    // the landmark depths.
    const Eigen::Vector3d origin = poses.front().translation;
    auto rescale = [&](double* pose) {
      for (int i = 0; i < 3; ++i) pose[i] = origin[i] + k * (pose[i] - origin[i]);
    };
    for (auto& frame : window) rescale(frame->pose.data());
    if (prior) {
      const std::vector<double*>& blocks = prior->kept_blocks();
      for (size_t b = 0; b < blocks.size(); ++b) {
        const bool is_pose = std::any_of(window.begin(), window.end(),
                                         [&](const Frame* frame) { return frame->pose.data() == blocks[b]; });
        if (!is_pose) continue;
        std::vector<double> x0 = prior->x0(static_cast<int>(b));
        rescale(x0.data());
        prior->SetX0(static_cast<int>(b), x0);
      }
    }
    for (std::optional<Rigid3d>* pose : {&last_pose, &previous_pose}) {
      if (*pose) (*pose)->translation = origin + k * ((*pose)->translation - origin);
    }
    for (auto& [id, lm] : landmarks) {
      if (lm.triangulated) lm.inverse_depth /= camera_k[lm.camera];
    }
    entry.applied_ratio = k;
    entry.camera_scales = camera_k;
    entry.applied = true;
    log("applied to window positions, prior and landmark inverse depths");
  }

  // ---------------------------------------------------------------- initialisation

  void StartFromInitialization(const InitializationResult& init, FrameEstimate* estimate) {
    // The new segment's world: the first segment's world is the rig at the
    // anchor frame; a later one is placed at the last good pose.
    const Rigid3d world_from_init = segment > 0 && last_pose ? *last_pose : Rigid3d();
    ClearWindow();
    landmarks.clear();
    prior.reset();
    solves_since_correction = 0;
    for (size_t k = 0; k < init.frame_index.size(); ++k) {
      auto it = std::find_if(init_buffer.begin(), init_buffer.end(), [&](const RigFrameObservations& f) {
        return f.frame_index == init.frame_index[k];
      });
      MCVO_CHECK_MSG(it != init_buffer.end(), "initialisation frame ", init.frame_index[k], " not buffered");
      Frame* frame = AcquireFrame();
      frame->frame_index = it->frame_index;
      frame->t_ns = it->t_ns;
      frame->segment = segment;
      frame->keyframe = true;
      frame->obs = *it;
      frame->SetWorldFromRig(world_from_init * init.world_from_rig[k]);
      window.push_back(frame);
    }
    while (static_cast<int>(window.size()) > options.window_size) {
      // No landmark exists yet: these keyframes leave without observations.
      finished_keyframes.push_back(FinishedKeyframe(window.front()));
      PopFront();
    }
    // Landmarks: anchored in the first window frame that saw them; depth
    // from the initialisation where it has the point.
    std::map<uint64_t, Eigen::Vector3d> init_points;
    for (const auto& lm : init.landmarks) init_points[lm.id] = world_from_init * lm.point_in_world;
    for (auto& frame : window) {
      CreateLandmarks(frame);
      for (auto& [id, ob] : FrameObservations(frame)) {
        auto it = landmarks.find(id);
        if (it == landmarks.end() || it->second.anchor_frame == frame) continue;
        if (HasCrossObservation(it->second, frame, ob.camera)) continue;
        it->second.observations.push_back(ob);
      }
    }
    for (auto& [id, lm] : landmarks) {
      auto point = init_points.find(id);
      if (point != init_points.end()) {
        const double depth = (WorldFromCam(*lm.anchor_frame, lm.anchor_camera).Inverse() * point->second)
                                 .dot(lm.anchor_bearing);
        if (depth > kMinLandmarkDistanceM && depth < kMaxLandmarkDistanceM) {
          lm.inverse_depth = 1.0 / depth;
          lm.triangulated = true;
          continue;
        }
      }
      Triangulate(&lm);
    }
    SolveWindow(estimate);
    RemoveOutliers();
    TriangulatePending();
    for (auto& frame : window)
      estimate->poses.push_back({frame->frame_index, frame->t_ns, frame->WorldFromRig()});
    previous_pose =
        window.size() >= 2 ? std::optional<Rigid3d>(window[window.size() - 2]->WorldFromRig()) : std::nullopt;
    last_pose = window.back()->WorldFromRig();

    ScaleLogEntry entry;
    entry.frame_index = window.back()->frame_index;
    entry.t_ns = window.back()->t_ns;
    entry.segment = segment;
    entry.event = segment == 0 ? "init" : "reinit";
    entry.camera_scales = init.camera_scales;
    entry.rms_residual_m = init.rig_scale.rms_residual_m;
    entry.singular_value_ratio = init.rig_scale.singular_value_ratio;
    entry.applied = true;
    // The initialiser's scale std (its bound when it reported none).
    const double init_sigma =
        init.relative_scale_sigma > 0.0 ? init.relative_scale_sigma : init_options.max_relative_scale_sigma;
    scale_filter.Start(init_sigma, last_pose->translation);
    entry.scale_sigma = init_sigma;
    if (init.source == ScaleSource::kArbitrary) {
      entry.scale_sigma = 0.0;
      entry.note = StrCat("arbitrary scale (one camera, ", rig.cameras[init.principal_camera].name,
                          "): unit = its travel over the initialisation window, frames ",
                          init.frame_index.front(), "-", init.frame_index.back());
    } else {
      entry.note = StrCat("scale from ",
                          init.source == ScaleSource::kRigRotation    ? "rig rotation"
                          : init.source == ScaleSource::kCrossCamera  ? "cross-camera baseline"
                          : init.source == ScaleSource::kOverlapStart ? "overlapping views without motion"
                                                                      : "rig rotation and cross-camera baseline",
                          "; principal camera ", rig.cameras[init.principal_camera].name, "; ",
                          init.cross_camera_matches, " cross-camera matches");
    }
    scale_log.push_back(std::move(entry));
    init_buffer.clear();
    state = EstimatorState::kTracking;
  }

  void StartNewSegment() {
    ++segment;
    state = EstimatorState::kInitializing;
    initializer.Reset();
    init_buffer.clear();
    for (auto& frame : window) {
      if (frame->keyframe) finished_keyframes.push_back(FinishedKeyframe(frame));
    }
    FinishAllLandmarks();
    ClearWindow();
    landmarks.clear();
    prior.reset();
  }

  // ---------------------------------------------------------------- per frame

  FrameEstimate AddFrame(const RigFrameObservations& input) {
    MCVO_CHECK_MSG(static_cast<int>(input.cameras.size()) == rig.NumCameras(), "frame ", input.frame_index,
                   " has ", input.cameras.size(), " cameras, the rig ", rig.NumCameras());
    FrameEstimate estimate;
    estimate.frame_index = input.frame_index;
    estimate.t_ns = input.t_ns;
    estimate.features_per_camera.assign(rig.NumCameras(), 0);
    estimate.landmarks_per_camera.assign(rig.NumCameras(), 0);
    for (int c = 0; c < rig.NumCameras(); ++c) {
      estimate.features_per_camera[c] = static_cast<int>(input.cameras[c].size());
    }
    if (state == EstimatorState::kTracking && !Track(input, &estimate)) {
      // Lost: a new segment starts with this frame.
      StartNewSegment();
      ScaleLogEntry entry;
      entry.frame_index = input.frame_index;
      entry.t_ns = input.t_ns;
      entry.segment = segment;
      entry.event = "lost";
      entry.note = StrCat("tracking lost: ", estimate.waiting_reason);
      scale_log.push_back(std::move(entry));
    }
    if (state == EstimatorState::kInitializing) {
      const auto start = std::chrono::steady_clock::now();
      init_buffer.push_back(input);
      while (static_cast<int>(init_buffer.size()) > init_options.window_size) init_buffer.pop_front();
      std::optional<InitializationResult> init = initializer.AddFrame(input);
      estimate.seconds_initializer = Seconds(start);
      if (init) {
        StartFromInitialization(*init, &estimate);
        estimate.has_pose = true;
        estimate.world_from_rig = window.back()->WorldFromRig();
        estimate.keyframe = true;
      } else {
        estimate.waiting_reason = initializer.WaitingReason();
      }
    }
    estimate.state = state;
    estimate.segment = segment;
    return estimate;
  }

  // Returns false when the frame's pose cannot be found.
  bool Track(const RigFrameObservations& input, FrameEstimate* estimate) {
    // A non-keyframe newest frame is dropped now.
    if (!window.empty() && !window.back()->keyframe) {
      RemoveFrameObservations(window.back());
      PopBack();
    }
    Frame* frame = AcquireFrame();
    frame->frame_index = input.frame_index;
    frame->t_ns = input.t_ns;
    frame->segment = segment;
    frame->obs = input;
    for (auto& features : frame->obs.cameras) {
      for (FeatureObservation& f : features) f.bearing.normalize();
    }
    Rigid3d prediction = *last_pose;
    if (previous_pose) prediction = *last_pose * (previous_pose->Inverse() * *last_pose);

    // Absolute pose against the triangulated landmarks.
    const auto pnp_start = std::chrono::steady_clock::now();
    std::vector<RigPnpCorrespondence> correspondences;
    std::vector<uint64_t> correspondence_ids;
    auto observations = FrameObservations(frame);
    for (const auto& [id, ob] : observations) {
      auto it = landmarks.find(id);
      if (it == landmarks.end() || !UsableInBa(it->second)) continue;
      correspondences.push_back({ob.camera, ob.bearing, LandmarkInWorld(it->second)});
      correspondence_ids.push_back(id);
    }
    RigPnpOptions pnp_options;
    pnp_options.threshold_px = options.pnp_threshold_px;
    pnp_options.focal_px = options.virtual_focal_px;
    pnp_options.min_inliers = options.min_pnp_inliers;
    const RigPnpResult pnp = SolveRigPnp(cam_from_rig, correspondences, pnp_options, &prediction);
    estimate->seconds_pnp = Seconds(pnp_start);
    estimate->pnp_inliers = pnp.num_inliers;
    if (!pnp.ok) {
      estimate->waiting_reason = StrCat("rig pose failed: ", pnp.reason);
      ReleaseFrame(frame);  // never entered the window
      return false;
    }
    frame->SetWorldFromRig(pnp.world_from_rig);
    // Observations: PnP outliers are left out.
    std::map<std::pair<uint64_t, int>, bool> outlier;
    for (size_t k = 0; k < correspondences.size(); ++k) {
      if (!pnp.inliers[k]) outlier[{correspondence_ids[k], correspondences[k].camera}] = true;
    }
    Frame* raw = frame;
    window.push_back(frame);
    for (const auto& [id, ob] : observations) {
      auto it = landmarks.find(id);
      if (it == landmarks.end()) continue;
      if (outlier.count({id, ob.camera}) != 0) continue;
      if (HasCrossObservation(it->second, raw, ob.camera)) continue;
      it->second.observations.push_back(ob);
    }
    TriangulatePending();

    const auto ba_start = std::chrono::steady_clock::now();
    SolveWindow(estimate);
    RemoveOutliers();
    estimate->seconds_ba = Seconds(ba_start);

    raw->keyframe = IsKeyframe(*raw);
    if (raw->keyframe) {
      CreateLandmarks(raw);
      int keyframes = 0;
      for (auto& f : window) keyframes += f->keyframe ? 1 : 0;
      if (keyframes > options.window_size) MarginalizeOldest(estimate);
    }
    // Scale correction once due, in the first window that turns enough for
    // the rig constraint to hold the scale (on a straight it cannot).
    if (!monocular && options.scale_correction_period > 0 &&
        solves_since_correction >= options.scale_correction_period &&
        WindowRotationDeg() >= options.scale_correction_min_rotation_deg) {
      ScaleCorrection(*raw, estimate);
    }

    // Report.
    for (auto& [id, lm] : landmarks) {
      if (!UsableInBa(lm)) continue;
      ++estimate->num_landmarks;
      for (const Observation& ob : lm.observations) {
        if (ob.frame == raw) ++estimate->landmarks_per_camera[ob.camera];
      }
    }
    estimate->has_pose = true;
    estimate->world_from_rig = raw->WorldFromRig();
    estimate->keyframe = raw->keyframe;
    estimate->poses.push_back({raw->frame_index, raw->t_ns, raw->WorldFromRig()});
    previous_pose = last_pose;
    last_pose = raw->WorldFromRig();
    return true;
  }

  std::vector<KeyframeEstimate> Finish() {
    std::vector<KeyframeEstimate> out = std::move(finished_keyframes);
    finished_keyframes.clear();
    for (auto& frame : window) {
      if (frame->keyframe) out.push_back(FinishedKeyframe(frame));
    }
    FinishAllLandmarks();
    return out;
  }
};

Estimator::Estimator(const Rig& rig, const InitializerOptions& init_options, const BackendOptions& options,
                     int threads)
    : impl_(std::make_unique<Impl>(rig, init_options, options, threads)) {}
Estimator::~Estimator() = default;

FrameEstimate Estimator::AddFrame(const RigFrameObservations& frame) { return impl_->AddFrame(frame); }

std::vector<KeyframeEstimate> Estimator::TakeFinishedKeyframes() {
  std::vector<KeyframeEstimate> out = std::move(impl_->finished_keyframes);
  impl_->finished_keyframes.clear();
  return out;
}

std::vector<ScaleLogEntry> Estimator::TakeScaleLog() {
  std::vector<ScaleLogEntry> out = std::move(impl_->scale_log);
  impl_->scale_log.clear();
  return out;
}

std::vector<MapLandmark> Estimator::TakeFinishedLandmarks() {
  std::vector<MapLandmark> out = std::move(impl_->finished_landmarks);
  impl_->finished_landmarks.clear();
  return out;
}

std::vector<KeyframeEstimate> Estimator::Finish() { return impl_->Finish(); }

double Estimator::SmallestRejectedScaleSigma() const { return impl_->initializer.SmallestRejectedScaleSigma(); }

}  // namespace mcvo
