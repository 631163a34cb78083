// Pose graph over keyframe rig poses (loop closure's last step): odometry
// edges between consecutive keyframes (the relative pose the visual
// odometry estimated) and loop edges (the relative pose a verified loop
// measured), optimised with Ceres. 6-DoF (SE3) by default; optionally Sim3
// (a scale per node, for residual scale drift: the loop edge then also
// measures the relative scale).
//
// Nodes. Node i is world_from_node_i = (s_i, R_i, t_i): a point p in node
// i's frame, in the odometry's unit of length there, is s_i R_i p + t_i in
// the world. SE3: s_i = 1. Ceres blocks: {tx, ty, tz, qx, qy, qz, qw}
// (EuclideanManifold<3> x EigenQuaternionManifold), Sim3: plus log(s_i)
// (one number, unconstrained). Node 0 is fixed, pose and scale (gauge).
//
// Edges. An edge i -> j measures M = (s_m, R_m, t_m) = i_from_j, the pose
// of node j in node i's frame (in node i's unit; SE3: s_m = 1). The graph
// predicts T_ij = T_wi^-1 T_wj = (s_j / s_i, R_i^T R_j, R_i^T (t_j - t_i) / s_i),
// and the residual is the error transform E = M^-1 T_ij
//   = (s_j / (s_i s_m), R_m^T R_ij, R_m^T (t_ij - t_m) / s_m),
// written in (tangent) numbers and whitened, rotation first:
//   r = [ Log(R_m^T R_ij) / sigma_rot,                    (3, radians)
//         R_m^T (t_ij - t_m) / s_m / sigma_trans,         (3, node i units)
//         (log s_j - log s_i - log s_m) / sigma_scale ]   (Sim3 only)
// i.e. r = W log(E) with the translation part of E itself (not SE3's
// J^-1-coupled tangent) and W = diag(1 / sigma). Zero iff the graph agrees
// with the measurement.
//
// Sigmas. Odometry edges (length L = |t_m|): sigma = per_m * L + floor for
// rotation, translation and (Sim3) scale: the relative scale of an
// odometry edge is measured as 1 with a sigma that grows with its length.
// Loop edges: fixed sigmas and a Cauchy loss whose scale is in sigmas (on
// the norm of the whitened residual), so one wrong loop cannot pull the
// whole graph.
//
// Robust schedule (graduated non-convexity, Black & Rangarajan 1996; Yang
// et al. 2020). A Cauchy loss started from the odometry rejects a correct
// first loop whose drift is large (every loop starts far out in the
// loss's flat tail). The solve therefore runs loop_loss_stages stages on
// one problem, each warm-started from the last: the first is plain least
// squares (every loop pulls fully), then the Cauchy scale shrinks by
// loop_loss_stage_factor per stage down to loop_loss_scale. A loop that
// agrees with the odometry and the other loops stays near zero residual; a
// loop that disagrees with them keeps a large residual and its weight
// falls with the scale. With one stage only the final loss is used.
//
// Deterministic: one thread, SPARSE_NORMAL_CHOLESKY (SuiteSparse when
// available, else Eigen's sparse Cholesky), iteration limits only.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

struct PoseGraphEdge {
  int from = 0;  // node indices (from != to)
  int to = 0;
  Rigid3d from_T_to;   // measured to-frame in from-frame (from_from_to), translation in from-node units
  double scale = 1.0;  // Sim3 only: measured s_to / s_from (1 for odometry); > 0. Ignored in SE3.
  bool loop = false;   // loop edge (robust loss, loop sigmas) or odometry edge
};

struct PoseGraphOptions {
  bool sim3 = false;
  // Odometry sigmas per metre of edge length (plus a floor). They must
  // cover the odometry's systematic drift over a loop, not only its noise:
  // independent edges accumulate as sqrt(edges) while a bias accumulates
  // linearly, and a first loop whose drift is many of these chain sigmas
  // is rejected by the robust loss. With these defaults a 200 m square
  // with 1 deg / 100 m yaw and 1 % / 100 m scale drift closes (end point
  // 1.43 -> 0.03 m), and so does a 1 km one (35.9 -> 0.01 m);
  // 0.01 deg/m and 1 % (the first proposal) left the 200 m loop at 7
  // sigmas, down-weighted (tests/loop/pose_graph_test.cc).
  double odometry_rotation_sigma_deg_per_m = 0.05;
  double odometry_translation_sigma_per_m = 0.02;  // relative: 2 % of the edge length
  double odometry_rotation_sigma_floor_deg = 0.01;
  double odometry_translation_sigma_floor_m = 0.005;
  double odometry_scale_sigma_per_m = 0.002;   // Sim3: of log(relative scale), per metre
  double odometry_scale_sigma_floor = 0.0001;  // Sim3: so that short edges keep a finite weight
  double loop_rotation_sigma_deg = 0.2;        // a rig pose verified on several cameras
  double loop_translation_sigma_m = 0.1;
  double loop_scale_sigma = 0.02;  // Sim3: of log(scale)
  // Final Cauchy scale, in sigmas, on the norm of the whitened loop
  // residual (6 numbers, 7 in Sim3). 3: about the 95 % bound of a correct
  // loop's |r| (chi-square with 6 degrees of freedom: 12.6 = 3.55^2); at 1
  // a correct loop (|r| ~ 2.4 on average) is already down-weighted, and the
  // 200 m square above is left open at 14 sigmas.
  double loop_loss_scale = 3.0;
  // Stages of the robust schedule (see above): 1 = the final loss only;
  // n > 1 = least squares, then loop_loss_scale * factor^(n-2), ...,
  // loop_loss_scale.
  int loop_loss_stages = 4;
  double loop_loss_stage_factor = 4.0;
  int max_iterations = 100;  // per stage
  // Throws InputError naming the field ("/loop/pose_graph/...").
  void Check() const;
};

struct PoseGraphResult {
  bool ok = false;
  std::string reason;                    // why not ok (then world_from_node is the input)
  std::vector<Rigid3d> world_from_node;  // optimised (Sim3: translation and rotation; scale separately)
  std::vector<double> node_scale;        // Sim3: s_i per node (1 otherwise)
  int iterations = 0;                    // over all stages
  // Cost (Ceres' 1/2 sum of robustified squared whitened residuals, with
  // the final loop loss) at the input and after the optimisation.
  double initial_cost = 0.0;
  double final_cost = 0.0;
  // Per loop edge (in edge order among loop edges): its residual norm in
  // sigmas after the optimisation (large: the loop disagrees with the rest).
  std::vector<double> loop_residual_sigmas;
};

// world_from_node: the initial poses (the odometry, scale 1); edges:
// indices into it. MCVO_CHECKs the indices (in range, from != to) and the
// edge scales (> 0); throws InputError if options.Check() does. A graph
// without loop edges returns the input unchanged (ok, 0 iterations, zero
// costs). ok is false only when Ceres returns no usable solution. Nodes in
// no edge stay as they are; a part of the graph not connected to node 0
// has no fixed gauge (Levenberg-Marquardt's damping keeps it near the input).
PoseGraphResult OptimizePoseGraph(const std::vector<Rigid3d>& world_from_node,
                                  const std::vector<PoseGraphEdge>& edges, const PoseGraphOptions& options);

// Carries a pose-graph correction to the non-keyframe poses: each pose
// keeps its pose relative to the latest node at or before its time (before
// the first node: the first node),
//   world_from_pose_after = node_after * node_before^-1 * pose_before.
// node_t_ns must be strictly increasing and the node vectors of equal size;
// pose_t_ns and poses_before of equal size, in any order (MCVO_CHECK). No
// nodes: the poses are returned unchanged. A pose equal to its node's
// before-pose becomes that node's after-pose (to rounding).
std::vector<Rigid3d> CorrectPoses(const std::vector<int64_t>& node_t_ns,
                                  const std::vector<Rigid3d>& node_before,
                                  const std::vector<Rigid3d>& node_after,
                                  const std::vector<int64_t>& pose_t_ns,
                                  const std::vector<Rigid3d>& poses_before);

// Sim3 results: the same, with node i's after-pose the similarity
// (node_scale[i], node_after[i]) (PoseGraphResult::node_scale and
// world_from_node), so the pose's translation relative to its node (in the
// odometry's unit there; node_before has scale 1) is scaled by the node's
// scale while its rotation stays rigid:
//   node_from_pose = node_before^-1 * pose_before,
//   world_from_pose_after = (R_a R_np, s_a R_a t_np + t_a).
// With all scales 1 it is the function above (the same numbers).
// node_scale has one positive entry per node (MCVO_CHECK).
std::vector<Rigid3d> CorrectPoses(const std::vector<int64_t>& node_t_ns,
                                  const std::vector<Rigid3d>& node_before,
                                  const std::vector<Rigid3d>& node_after,
                                  const std::vector<double>& node_scale,
                                  const std::vector<int64_t>& pose_t_ns,
                                  const std::vector<Rigid3d>& poses_before);

// Carries corrections known at nodes (refined keyframes) to the poses
// between them, continuously in time within a segment. For a pose at t
// between two nodes a, b of its segment (t_a <= t < t_b), each of the two
// predicts it as CorrectPoses does with its own node (the translation
// relative to the node scaled by node_scale[a], the stretch of the interval
// a-b), and the pose is the blend of the two predictions by
// tau = (t - t_a) / (t_b - t_a): rotations by slerp, translations linearly.
// A pose with only an earlier (or only a later) node in its segment follows
// that node alone, with that node's scale; a pose whose segment has neither
// next to it follows the latest node at or before it (before the first:
// the first), as CorrectPoses. So a pose equal to its node's before-pose
// becomes that node's after-pose, and a pose just before node b is carried
// by b's correction, not by a's (no jump at b when the nodes' corrections
// differ). node_segment, node_scale: one per node; pose_segment: one per
// pose (MCVO_CHECK); the node conditions of CorrectPoses hold.
std::vector<Rigid3d> InterpolateCorrections(const std::vector<int64_t>& node_t_ns, const std::vector<int>& node_segment,
                                            const std::vector<Rigid3d>& node_before,
                                            const std::vector<Rigid3d>& node_after,
                                            const std::vector<double>& node_scale,
                                            const std::vector<int64_t>& pose_t_ns,
                                            const std::vector<int>& pose_segment,
                                            const std::vector<Rigid3d>& poses_before);

}  // namespace mcvo
