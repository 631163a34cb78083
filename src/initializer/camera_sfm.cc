// Monocular window SfM on unit bearings (see camera_sfm.h).
//
// Poses are kept as anchor_from_cam (rotation, centre of the camera in anchor
// coordinates), the form OpenGV returns for both the relative pose (view 1 =
// anchor) and the absolute pose (world = anchor).
//
// Bundle adjustment residual (tangent plane of the unit sphere, as the back
// end's): for an observation f (unit) of point X in frame k,
//   d = R_k^T (X - c_k),   n = d / |d|,   e = focal_px * B_f^T n,
// B_f a 3x2 orthonormal basis of the plane orthogonal to f, so e is the
// angular error in pixels at focal_px for small errors, for any direction of
// f (fisheyes beyond 90 deg). Gauge: frame l is held at the identity; the
// centre of frame r lives on the unit sphere (Ceres SphereManifold), which
// fixes the scale at |c_r| = 1 without a penalty.
#include "mcvo/initializer/camera_sfm.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <ceres/ceres.h>
#include <ceres/product_manifold.h>
#include <ceres/sphere_manifold.h>
#include <Eigen/Geometry>
#include <opengv/absolute_pose/CentralAbsoluteAdapter.hpp>
#include <opengv/relative_pose/CentralRelativeAdapter.hpp>
#include <opengv/sac/Ransac.hpp>
#include <opengv/sac_problems/absolute_pose/AbsolutePoseSacProblem.hpp>
#include <opengv/sac_problems/relative_pose/CentralRelativePoseSacProblem.hpp>

#include "absolute_pose_refine.h"
#include "bearing_residual.h"
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

constexpr double kRadToDeg = 180.0 / M_PI;

// OpenGV's error 1 - cos(angle) for an angle of `px` pixels at `focal`.
double OpenGvThreshold(double px, double focal) { return 1.0 - std::cos(std::atan(px / focal)); }

// The window's observations, indexed both ways. std::map: id order everywhere.
struct WindowData {
  std::vector<std::map<uint64_t, Eigen::Vector3d>> by_frame;  // frame -> id -> bearing
  std::map<uint64_t, std::vector<std::pair<int, Eigen::Vector3d>>>
      by_id;  // id -> (frame, bearing), frame order
};

WindowData Organise(int num_frames, const std::vector<WindowObservation>& observations) {
  WindowData data;
  data.by_frame.resize(static_cast<size_t>(num_frames));
  for (const WindowObservation& obs : observations) {
    MCVO_CHECK_MSG(obs.frame >= 0 && obs.frame < num_frames, "observation of feature ", obs.id, " in frame ",
                   obs.frame, ", window has ", num_frames, " frames");
    const double norm = obs.bearing.norm();
    MCVO_CHECK_MSG(norm > 0.0 && std::isfinite(norm), "feature ", obs.id, " frame ", obs.frame,
                   ": bearing is zero or not finite");
    const bool inserted =
        data.by_frame[static_cast<size_t>(obs.frame)].emplace(obs.id, obs.bearing / norm).second;
    MCVO_CHECK_MSG(inserted, "feature ", obs.id, " observed twice in frame ", obs.frame);
  }
  for (int k = 0; k < num_frames; ++k) {
    for (const auto& [id, bearing] : data.by_frame[static_cast<size_t>(k)])
      data.by_id[id].emplace_back(k, bearing);
  }
  return data;
}

// Runs an OpenGV RANSAC, refines the winner on its inliers (`refine`, or
// OpenGV's own nonlinear refinement when empty) and re-selects (the
// refinement is kept when it keeps at least as many inliers). Returns false
// when no model was found.
template <typename Problem>
bool RansacRefine(
    const std::shared_ptr<Problem>& problem, double threshold, int max_iterations, typename Problem::model_t* model,
    std::vector<int>* inliers,
    const std::function<void(const std::vector<int>&, const typename Problem::model_t&, typename Problem::model_t*)>&
        refine = {}) {
  opengv::sac::Ransac<Problem> ransac;
  ransac.sac_model_ = problem;
  ransac.threshold_ = threshold;
  ransac.max_iterations_ = max_iterations;
  ransac.probability_ = 0.99;
  if (!ransac.computeModel(0)) return false;
  *model = ransac.model_coefficients_;
  *inliers = ransac.inliers_;
  if (inliers->size() > 5) {
    typename Problem::model_t refined;
    if (refine) {
      refine(*inliers, *model, &refined);
    } else {
      problem->optimizeModelCoefficients(*inliers, *model, refined);
    }
    std::vector<int> refined_inliers;
    if (refined.allFinite()) problem->selectWithinDistance(refined, threshold, refined_inliers);
    if (refined_inliers.size() >= inliers->size()) {
      *model = refined;
      inliers->swap(refined_inliers);
    }
  }
  std::sort(inliers->begin(), inliers->end());
  return true;
}

class WindowSfm {
 public:
  WindowSfm(int num_frames, int anchor, int reference, const std::vector<WindowObservation>& observations,
            const CameraSfmOptions& options)
      : num_frames_(num_frames),
        anchor_(anchor),
        reference_(reference),
        options_(options),
        data_(Organise(num_frames, observations)),
        poses_(static_cast<size_t>(num_frames)) {}

  CameraSfmResult Run() {
    CameraSfmResult result;
    if (!TwoView(&result)) return result;
    // The other frames, nearest to the anchor first (ties: the earlier frame).
    std::vector<int> order;
    for (int k = 0; k < num_frames_; ++k) {
      if (k != anchor_ && k != reference_) order.push_back(k);
    }
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return std::abs(a - anchor_) < std::abs(b - anchor_); });
    for (int k : order) {
      if (!PoseFrame(k, &result.reason)) return result;
      TriangulateNew();
    }
    if (!Adjust(&result.reason)) return result;
    result.ok = true;
    result.anchor_from_cam.reserve(poses_.size());
    for (const auto& pose : poses_) result.anchor_from_cam.push_back(*pose);
    result.points = points_;
    result.rms_reprojection_px = rms_px_;
    return result;
  }

 private:
  double Focal() const { return options_.focal_px; }

  // Steps 1 and 2: 5-point relative pose anchor -> reference, triangulation.
  bool TwoView(CameraSfmResult* result) {
    std::vector<uint64_t> ids;
    opengv::bearingVectors_t bearings_l, bearings_r;
    const auto& frame_l = data_.by_frame[static_cast<size_t>(anchor_)];
    const auto& frame_r = data_.by_frame[static_cast<size_t>(reference_)];
    for (const auto& [id, bearing] : frame_l) {
      const auto it = frame_r.find(id);
      if (it == frame_r.end()) continue;
      ids.push_back(id);
      bearings_l.push_back(bearing);
      bearings_r.push_back(it->second);
    }
    const int n = static_cast<int>(ids.size());
    if (n < options_.min_correspondences) {
      result->reason = StrCat("too few correspondences between frames ", anchor_, " and ", reference_, " (",
                              n, " < ", options_.min_correspondences, ")");
      return false;
    }
    // OpenGV view 1 = anchor, view 2 = reference: the model is [R t] with R
    // the rotation and t the centre of the reference camera in the anchor.
    opengv::relative_pose::CentralRelativeAdapter adapter(bearings_l, bearings_r);
    using Problem = opengv::sac_problems::relative_pose::CentralRelativePoseSacProblem;
    const auto problem = std::make_shared<Problem>(adapter, Problem::STEWENIUS, /*randomSeed=*/false);
    opengv::transformation_t model;
    std::vector<int> inliers;
    if (!RansacRefine(problem, OpenGvThreshold(options_.ransac_threshold_px, Focal()),
                      options_.ransac_max_iterations, &model, &inliers)) {
      result->reason = StrCat("5-point RANSAC found no relative pose between frames ", anchor_, " and ",
                              reference_, " (", n, " correspondences)");
      return false;
    }
    result->num_inliers = static_cast<int>(inliers.size());
    if (result->num_inliers < options_.min_inliers) {
      result->reason = StrCat("too few 5-point inliers between frames ", anchor_, " and ", reference_, " (",
                              result->num_inliers, " < ", options_.min_inliers, ")");
      return false;
    }
    const Eigen::Matrix3d rotation = model.leftCols<3>();
    const Eigen::Vector3d centre = model.col(3);
    if (!rotation.allFinite() || !(centre.norm() > 0.0) || !centre.allFinite()) {
      result->reason = StrCat("degenerate relative pose between frames ", anchor_, " and ", reference_);
      return false;
    }
    poses_[static_cast<size_t>(anchor_)] = Rigid3d();
    poses_[static_cast<size_t>(reference_)] = Rigid3d(rotation, centre.normalized());

    double parallax_sum = 0.0;
    for (int index : inliers) {
      parallax_sum += AngleBetween(bearings_l[static_cast<size_t>(index)],
                                   rotation * bearings_r[static_cast<size_t>(index)]);
    }
    result->mean_parallax_deg = kRadToDeg * parallax_sum / static_cast<double>(inliers.size());

    for (int index : inliers) TriangulateFeature(ids[static_cast<size_t>(index)]);
    const int triangulated = static_cast<int>(points_.size());
    if (triangulated < options_.min_points_for_pnp) {
      result->reason =
          StrCat("too little parallax between frames ", anchor_, " and ", reference_, ": ", triangulated,
                 " of ", result->num_inliers,
                 " inliers triangulated at >= ", FormatDouble(options_.min_triangulation_angle_deg),
                 " deg (< ", options_.min_points_for_pnp, " needed; mean parallax ",
                 FormatFixed(result->mean_parallax_deg, 2), " deg)");
      return false;
    }
    return true;
  }

  // Triangulates feature `id` from the pair of posed frames whose rays are
  // the furthest apart; keeps it when the angle, the cheirality and the
  // reprojection errors in both frames pass. Returns whether it was added.
  bool TriangulateFeature(uint64_t id) {
    const auto& track = data_.by_id.at(id);
    std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> rays;  // (centre, direction) in the anchor
    std::vector<size_t> obs_index;
    for (size_t o = 0; o < track.size(); ++o) {
      const auto& pose = poses_[static_cast<size_t>(track[o].first)];
      if (!pose) continue;
      rays.emplace_back(pose->translation, pose->rotation * track[o].second);
      obs_index.push_back(o);
    }
    if (rays.size() < 2) return false;
    size_t best_a = 0, best_b = 0;
    double best_angle = -1.0;
    for (size_t a = 0; a < rays.size(); ++a) {
      for (size_t b = a + 1; b < rays.size(); ++b) {
        const double angle = AngleBetween(rays[a].second, rays[b].second);
        if (angle > best_angle) {
          best_angle = angle;
          best_a = a;
          best_b = b;
        }
      }
    }
    if (best_angle * kRadToDeg < options_.min_triangulation_angle_deg) return false;
    const std::optional<Eigen::Vector3d> point =
        TriangulateMidpoint(rays[best_a].first, rays[best_a].second, rays[best_b].first, rays[best_b].second);
    if (!point) return false;
    for (size_t r : {best_a, best_b}) {
      const auto& obs = track[obs_index[r]];
      if (!(ReprojectionPx(*poses_[static_cast<size_t>(obs.first)], *point, obs.second, Focal()) <=
            options_.max_reprojection_px)) {
        return false;
      }
    }
    points_[id] = *point;
    return true;
  }

  // Features seen in at least two posed frames and not yet triangulated.
  void TriangulateNew() {
    for (const auto& [id, track] : data_.by_id) {
      if (points_.count(id) != 0 || track.size() < 2) continue;
      TriangulateFeature(id);
    }
  }

  // Step 3: absolute pose of frame k from the triangulated points it sees.
  bool PoseFrame(int k, std::string* reason) {
    std::vector<uint64_t> ids;
    opengv::bearingVectors_t bearings;
    opengv::points_t points;
    for (const auto& [id, bearing] : data_.by_frame[static_cast<size_t>(k)]) {
      const auto it = points_.find(id);
      if (it == points_.end()) continue;
      ids.push_back(id);
      bearings.push_back(bearing);
      points.push_back(it->second);
    }
    const int n = static_cast<int>(ids.size());
    if (n < options_.min_points_for_pnp) {
      *reason = StrCat("frame ", k, " cannot be posed: it sees ", n, " triangulated points (< ",
                       options_.min_points_for_pnp, ")");
      return false;
    }
    // Model [R t]: rotation anchor_from_cam and the camera centre in the anchor.
    opengv::absolute_pose::CentralAbsoluteAdapter adapter(bearings, points);
    using Problem = opengv::sac_problems::absolute_pose::AbsolutePoseSacProblem;
    const auto problem = std::make_shared<Problem>(adapter, Problem::KNEIP, /*randomSeed=*/false);
    opengv::transformation_t model;
    std::vector<int> inliers;
    const auto refine = [&](const std::vector<int>& in, const opengv::transformation_t& from,
                            opengv::transformation_t* to) {
      *to = initializer_internal::RefineAbsolutePose(bearings, points, in, Focal(), Rigid3d::FromMatrix(from))
                .ToMatrix3x4();
    };
    if (!RansacRefine<Problem>(problem, OpenGvThreshold(options_.max_reprojection_px, Focal()),
                               options_.ransac_max_iterations, &model, &inliers, refine) ||
        !model.allFinite()) {
      *reason = StrCat("frame ", k, " cannot be posed: P3P RANSAC found no pose (", n, " points)");
      return false;
    }
    if (static_cast<int>(inliers.size()) < options_.min_points_for_pnp) {
      *reason = StrCat("frame ", k, " cannot be posed: ", inliers.size(), " P3P inliers of ", n, " (< ",
                       options_.min_points_for_pnp, ")");
      return false;
    }
    poses_[static_cast<size_t>(k)] =
        Rigid3d(Eigen::Matrix3d(model.leftCols<3>()), Eigen::Vector3d(model.col(3)));
    return true;
  }

  // Observations of the triangulated points in posed frames whose error is
  // below max_reprojection_px. A point keeps none when fewer than two, or
  // fewer than half, of its observations pass: a track that is wrong in most
  // frames (a drifting track fits any depth along the epipolar line of two
  // views) is dropped as a whole.
  struct BaObservation {
    int frame;
    uint64_t id;
    Eigen::Vector3d bearing;
  };
  std::vector<BaObservation> CollectObservations() const {
    std::vector<BaObservation> out;
    for (const auto& [id, point] : points_) {
      int total = 0;
      std::vector<BaObservation> inliers;
      for (const auto& [frame, bearing] : data_.by_id.at(id)) {
        const auto& pose = poses_[static_cast<size_t>(frame)];
        if (!pose) continue;
        ++total;
        if (ReprojectionPx(*pose, point, bearing, Focal()) <= options_.max_reprojection_px) {
          inliers.push_back({frame, id, bearing});
        }
      }
      const int n = static_cast<int>(inliers.size());
      if (n >= 2 && 2 * n >= total) out.insert(out.end(), inliers.begin(), inliers.end());
    }
    return out;
  }

  bool Solve(const std::vector<BaObservation>& observations) {
    const size_t nf = poses_.size();
    std::vector<PoseBlock> blocks(nf);
    for (size_t k = 0; k < nf; ++k) blocks[k] = ToPoseBlock(*poses_[k]);
    blocks[static_cast<size_t>(reference_)].tail<3>().normalize();
    std::map<uint64_t, Eigen::Vector3d> points = points_;

    // Manifolds and the loss are shared by many blocks and owned here.
    ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>> pose_manifold;
    ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::SphereManifold<3>> reference_manifold;
    ceres::HuberLoss huber(options_.ba_huber_px);
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    std::map<uint64_t, int> count;
    for (const auto& obs : observations) ++count[obs.id];
    for (const auto& obs : observations) {
      if (count[obs.id] < 2) continue;
      auto* cost = new TangentBearingCost(obs.bearing, Focal());
      problem.AddResidualBlock(cost, &huber, blocks[static_cast<size_t>(obs.frame)].data(),
                               points.at(obs.id).data());
    }
    for (size_t k = 0; k < nf; ++k) {
      double* block = blocks[k].data();
      if (!problem.HasParameterBlock(block)) continue;
      if (static_cast<int>(k) == anchor_) {
        problem.SetParameterBlockConstant(block);
      } else if (static_cast<int>(k) == reference_) {
        problem.SetManifold(block, &reference_manifold);
      } else {
        problem.SetManifold(block, &pose_manifold);
      }
    }
    const ceres::Solver::Options solver_options =
        initializer_internal::DeterministicBaOptions(options_.max_ba_iterations);
    ceres::Solver::Summary summary;
    if (options_.max_ba_iterations > 0 && problem.NumResidualBlocks() > 0) {
      ceres::Solve(solver_options, &problem, &summary);
    }

    for (size_t k = 0; k < nf; ++k) {
      if (!blocks[k].allFinite()) return false;
      poses_[k] = FromPoseBlock(blocks[k]);
    }
    for (auto& [id, point] : points) {
      if (!point.allFinite()) return false;
    }
    points_ = std::move(points);
    return true;
  }

  // Step 4: bundle adjustment; observations beyond max_reprojection_px are
  // then dropped and the adjustment repeated once.
  bool Adjust(std::string* reason) {
    std::vector<BaObservation> observations = CollectObservations();
    if (!Solve(observations)) {
      *reason = "bundle adjustment failed (non-finite result)";
      return false;
    }
    std::vector<BaObservation> kept = CollectObservations();
    if (kept.size() != observations.size()) {
      if (!Solve(kept)) {
        *reason = "bundle adjustment failed (non-finite result)";
        return false;
      }
      kept = CollectObservations();
    }
    // Points without two good observations go.
    std::map<uint64_t, int> count;
    for (const auto& obs : kept) ++count[obs.id];
    for (auto it = points_.begin(); it != points_.end();) {
      it = count[it->first] >= 2 ? std::next(it) : points_.erase(it);
    }
    double sum_sq = 0.0;
    for (const auto& obs : kept) {
      const double e =
          ReprojectionPx(*poses_[static_cast<size_t>(obs.frame)], points_.at(obs.id), obs.bearing, Focal());
      sum_sq += e * e;
    }
    rms_px_ = kept.empty() ? 0.0 : std::sqrt(sum_sq / static_cast<double>(kept.size()));
    return true;
  }

  const int num_frames_;
  const int anchor_;
  const int reference_;
  const CameraSfmOptions& options_;
  const WindowData data_;
  std::vector<std::optional<Rigid3d>> poses_;   // anchor_from_cam per frame
  std::map<uint64_t, Eigen::Vector3d> points_;  // in the anchor camera
  double rms_px_ = 0.0;
};

}  // namespace

CameraSfmResult SolveCameraWindowSfm(int num_frames, int anchor_frame, int reference_frame,
                                     const std::vector<WindowObservation>& observations,
                                     const CameraSfmOptions& options) {
  MCVO_CHECK_MSG(0 <= anchor_frame && anchor_frame < reference_frame && reference_frame < num_frames,
                 "need 0 <= anchor (", anchor_frame, ") < reference (", reference_frame, ") < frames (",
                 num_frames, ")");
  WindowSfm sfm(num_frames, anchor_frame, reference_frame, observations, options);
  return sfm.Run();
}

}  // namespace mcvo
