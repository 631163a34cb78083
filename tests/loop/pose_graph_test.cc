// Pose graph of loop closure (include/mcvo/loop/pose_graph.h): square
// trajectories whose odometry drifts in yaw and scale, closed by correct
// and wrong loop edges, in SE3 and Sim3; carrying the correction to
// non-keyframe poses; option checks; the timing of a 2000-node graph.
#include "mcvo/loop/pose_graph.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

Eigen::Quaterniond Rpy(double roll, double pitch, double yaw) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
}

// Ground truth: nodes 1 m apart, `laps` times counter-clockwise around a
// square of side `side` metres from the origin (heading +x), turning by 90
// degrees at the corners, with a gentle wave in height, roll and pitch so
// the graph is not planar. 4 * side * laps + 1 nodes; the last is at the
// first's place and heading (not exactly its height and tilt).
std::vector<Rigid3d> SquarePath(int side, int laps) {
  const Eigen::Vector2d corners[4] = {{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}, {0.0, 1.0}};
  const Eigen::Vector2d directions[4] = {{1.0, 0.0}, {0.0, 1.0}, {-1.0, 0.0}, {0.0, -1.0}};
  const int lap_length = 4 * side;
  std::vector<Rigid3d> path;
  for (int k = 0; k <= lap_length * laps; ++k) {
    const int u = k % lap_length;
    const int edge = u / side;
    const Eigen::Vector2d xy =
        corners[edge] * static_cast<double>(side) + directions[edge] * static_cast<double>(u % side);
    const double z = 0.5 * std::sin(2.0 * kPi * k / 37.0);
    const Eigen::Quaterniond rotation =
        Rpy(0.02 * std::sin(k / 13.0), 0.02 * std::cos(k / 17.0), edge * 0.5 * kPi);
    path.emplace_back(rotation, Eigen::Vector3d(xy.x(), xy.y(), z));
  }
  return path;
}

// Odometry with a drift: every edge turns by yaw_deg_per_m * length too
// much about its from-frame's z axis, and its translation is scaled by the
// odometry's scale factor k(s) = 1 + scale_per_m * s at the edge's middle
// (s: path length). The chained poses start at the truth.
struct Odometry {
  std::vector<Rigid3d> world_from_node;
  std::vector<PoseGraphEdge> edges;
  std::vector<double> factor;  // k at each node (s_i = 1 / k_i in a Sim3 graph)
};

Odometry MakeOdometry(const std::vector<Rigid3d>& truth, double yaw_deg_per_m, double scale_per_m) {
  Odometry odometry;
  odometry.world_from_node.push_back(truth[0]);
  odometry.factor.push_back(1.0);
  double travelled = 0.0;
  for (size_t k = 0; k + 1 < truth.size(); ++k) {
    const Rigid3d relative = truth[k].Inverse() * truth[k + 1];
    const double length = relative.translation.norm();
    const double factor = 1.0 + scale_per_m * (travelled + 0.5 * length);
    travelled += length;
    const Eigen::Quaterniond yaw(
        Eigen::AngleAxisd(yaw_deg_per_m * length * kDegToRad, Eigen::Vector3d::UnitZ()));
    PoseGraphEdge edge;
    edge.from = static_cast<int>(k);
    edge.to = static_cast<int>(k + 1);
    edge.from_T_to = Rigid3d(yaw * relative.rotation, factor * relative.translation);
    odometry.edges.push_back(edge);
    odometry.world_from_node.push_back(odometry.world_from_node.back() * edge.from_T_to);
    odometry.factor.push_back(1.0 + scale_per_m * travelled);
  }
  return odometry;
}

// A loop edge as a verified loop would measure it: the true relative pose,
// its translation in the from-node's odometry unit and the relative scale
// s_to / s_from = k_from / k_to.
PoseGraphEdge LoopEdge(const std::vector<Rigid3d>& truth, const Odometry& odometry, int from, int to) {
  PoseGraphEdge edge;
  edge.from = from;
  edge.to = to;
  edge.loop = true;
  const Rigid3d relative = truth[from].Inverse() * truth[to];
  edge.from_T_to = Rigid3d(relative.rotation, odometry.factor[from] * relative.translation);
  edge.scale = odometry.factor[from] / odometry.factor[to];
  return edge;
}

double EndPointError(const std::vector<Rigid3d>& estimate, const std::vector<Rigid3d>& truth) {
  return (estimate.back().translation - truth.back().translation).norm();
}

// RMS position error, without alignment (node 0 is fixed at the truth).
double Ate(const std::vector<Rigid3d>& estimate, const std::vector<Rigid3d>& truth) {
  double sum = 0.0;
  for (size_t i = 0; i < truth.size(); ++i)
    sum += (estimate[i].translation - truth[i].translation).squaredNorm();
  return std::sqrt(sum / static_cast<double>(truth.size()));
}

double MaxPositionDifference(const std::vector<Rigid3d>& a, const std::vector<Rigid3d>& b) {
  double worst = 0.0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, (a[i].translation - b[i].translation).norm());
  return worst;
}

double RotationDifferenceDeg(const Rigid3d& a, const Rigid3d& b) {
  return a.rotation.angularDistance(b.rotation) / kDegToRad;
}

void ExpectBitIdentical(const PoseGraphResult& a, const PoseGraphResult& b) {
  ASSERT_EQ(a.world_from_node.size(), b.world_from_node.size());
  for (size_t i = 0; i < a.world_from_node.size(); ++i) {
    EXPECT_EQ(0, std::memcmp(a.world_from_node[i].rotation.coeffs().data(),
                             b.world_from_node[i].rotation.coeffs().data(), 4 * sizeof(double)));
    EXPECT_EQ(0, std::memcmp(a.world_from_node[i].translation.data(), b.world_from_node[i].translation.data(),
                             3 * sizeof(double)));
  }
  EXPECT_EQ(a.node_scale, b.node_scale);
  EXPECT_EQ(a.loop_residual_sigmas, b.loop_residual_sigmas);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.final_cost, b.final_cost);
}

TEST(PoseGraph, WithoutLoopEdgesTheResultIsTheInput) {
  const std::vector<Rigid3d> truth = SquarePath(50, 1);
  const Odometry odometry = MakeOdometry(truth, 0.01, 1e-4);
  for (const bool sim3 : {false, true}) {
    PoseGraphOptions options;
    options.sim3 = sim3;
    const PoseGraphResult result = OptimizePoseGraph(odometry.world_from_node, odometry.edges, options);
    ASSERT_TRUE(result.ok) << result.reason;
    EXPECT_EQ(result.iterations, 0);
    EXPECT_TRUE(result.loop_residual_sigmas.empty());
    ASSERT_EQ(result.world_from_node.size(), odometry.world_from_node.size());
    for (size_t i = 0; i < truth.size(); ++i) {
      EXPECT_EQ(result.world_from_node[i].translation, odometry.world_from_node[i].translation);
      EXPECT_EQ(result.world_from_node[i].rotation.coeffs(), odometry.world_from_node[i].rotation.coeffs());
      EXPECT_EQ(result.node_scale[i], 1.0);
    }
  }
}

// Odometry and loop measured without error: the truth is the optimum, the
// residuals vanish there, and the solver stays on it.
TEST(PoseGraph, ConsistentGraphStaysAtTheTruth) {
  const std::vector<Rigid3d> truth = SquarePath(20, 1);
  const Odometry odometry = MakeOdometry(truth, 0.0, 0.0);
  std::vector<PoseGraphEdge> edges = odometry.edges;
  edges.push_back(LoopEdge(truth, odometry, 0, static_cast<int>(truth.size()) - 1));
  edges.push_back(LoopEdge(truth, odometry, 10, 50));
  for (const bool sim3 : {false, true}) {
    PoseGraphOptions options;
    options.sim3 = sim3;
    const PoseGraphResult result = OptimizePoseGraph(odometry.world_from_node, edges, options);
    ASSERT_TRUE(result.ok) << result.reason;
    EXPECT_LT(MaxPositionDifference(result.world_from_node, truth), 1e-9);
    for (size_t i = 0; i < truth.size(); ++i) {
      EXPECT_LT(RotationDifferenceDeg(result.world_from_node[i], truth[i]), 1e-8);
      EXPECT_NEAR(result.node_scale[i], 1.0, 1e-12);
    }
    ASSERT_EQ(result.loop_residual_sigmas.size(), 2u);
    for (double r : result.loop_residual_sigmas) EXPECT_LT(r, 1e-6);
    EXPECT_LT(result.final_cost, 1e-12);
  }
}

TEST(PoseGraph, OneCorrectLoopRemovesMostOfTheDrift) {
  const std::vector<Rigid3d> truth = SquarePath(50, 1);  // 200 m, 201 nodes
  const Odometry odometry = MakeOdometry(truth, 0.01, 1e-4);
  const int last = static_cast<int>(truth.size()) - 1;
  std::vector<PoseGraphEdge> edges = odometry.edges;
  edges.push_back(LoopEdge(truth, odometry, 0, last));
  const PoseGraphResult result = OptimizePoseGraph(odometry.world_from_node, edges, PoseGraphOptions());
  ASSERT_TRUE(result.ok) << result.reason;

  const double end_before = EndPointError(odometry.world_from_node, truth);
  const double end_after = EndPointError(result.world_from_node, truth);
  const double ate_before = Ate(odometry.world_from_node, truth);
  const double ate_after = Ate(result.world_from_node, truth);
  std::printf(
      "one loop, 200 m: end point %.3f -> %.3f m, %.3f -> %.3f deg, ATE %.3f -> %.3f m, loop residual "
      "%.2f sigmas, %d iterations, cost %.1f -> %.3f\n",
      end_before, end_after, RotationDifferenceDeg(odometry.world_from_node.back(), truth.back()),
      RotationDifferenceDeg(result.world_from_node.back(), truth.back()), ate_before, ate_after,
      result.loop_residual_sigmas[0], result.iterations, result.initial_cost, result.final_cost);
  EXPECT_GT(end_before, 1.0);  // the drift is there
  EXPECT_LT(end_after, 0.2 * end_before);
  EXPECT_LT(ate_after, 0.8 * ate_before);  // SE3 cannot undo the scale drift
  EXPECT_LT(RotationDifferenceDeg(result.world_from_node.back(), truth.back()),
            0.2 * RotationDifferenceDeg(odometry.world_from_node.back(), truth.back()));
  ASSERT_EQ(result.loop_residual_sigmas.size(), 1u);
  EXPECT_LT(result.loop_residual_sigmas[0], 3.0);
  EXPECT_EQ(result.world_from_node[0].translation, truth[0].translation);  // node 0 fixed
  EXPECT_LT(result.final_cost, result.initial_cost);
}

// Two laps: loops from the second lap to the first at five places and one
// between the ends, all correct, and one wrong by 10 m.
struct TwoLaps {
  std::vector<Rigid3d> truth = SquarePath(50, 2);
  Odometry odometry = MakeOdometry(truth, 0.01, 1e-4);
  std::vector<PoseGraphEdge> correct_loops;
  PoseGraphEdge wrong_loop;

  TwoLaps() {
    for (int k : {0, 40, 90, 140, 190}) correct_loops.push_back(LoopEdge(truth, odometry, k, k + 200));
    correct_loops.push_back(LoopEdge(truth, odometry, 0, 400));
    wrong_loop = LoopEdge(truth, odometry, 70, 270);
    wrong_loop.from_T_to.translation += Eigen::Vector3d(10.0, 0.0, 0.0);
  }
  // Odometry, the correct loops, and the wrong one third when `with_wrong`.
  std::vector<PoseGraphEdge> Edges(bool with_wrong) const {
    std::vector<PoseGraphEdge> edges = odometry.edges;
    for (size_t i = 0; i < correct_loops.size(); ++i) {
      edges.push_back(correct_loops[i]);
      if (with_wrong && i == 2) edges.push_back(wrong_loop);
    }
    return edges;
  }
};

TEST(PoseGraph, WrongLoopIsDownWeighted) {
  const TwoLaps graph;
  const PoseGraphOptions options;
  const PoseGraphResult correct =
      OptimizePoseGraph(graph.odometry.world_from_node, graph.Edges(false), options);
  const PoseGraphResult with_wrong =
      OptimizePoseGraph(graph.odometry.world_from_node, graph.Edges(true), options);
  ASSERT_TRUE(correct.ok && with_wrong.ok);
  ASSERT_EQ(with_wrong.loop_residual_sigmas.size(), 7u);

  // Without the robust schedule (one least-squares-like stage), the wrong
  // loop bends the trajectory: what the loss prevents.
  PoseGraphOptions least_squares;
  least_squares.loop_loss_stages = 1;
  least_squares.loop_loss_scale = 1e9;
  const PoseGraphResult pulled =
      OptimizePoseGraph(graph.odometry.world_from_node, graph.Edges(true), least_squares);
  ASSERT_TRUE(pulled.ok);

  const double deviation = MaxPositionDifference(with_wrong.world_from_node, correct.world_from_node);
  const double deviation_least_squares =
      MaxPositionDifference(pulled.world_from_node, correct.world_from_node);
  std::printf("wrong loop: residual %.1f sigmas (correct loops:", with_wrong.loop_residual_sigmas[3]);
  for (size_t i = 0; i < 7; ++i) {
    if (i != 3) std::printf(" %.2f", with_wrong.loop_residual_sigmas[i]);
  }
  std::printf(
      "); max deviation from the correct-loops result %.4f m (least squares: %.3f m); ATE odometry %.3f, "
      "correct loops %.3f, with the wrong one %.3f m\n",
      deviation, deviation_least_squares, Ate(graph.odometry.world_from_node, graph.truth),
      Ate(correct.world_from_node, graph.truth), Ate(with_wrong.world_from_node, graph.truth));
  EXPECT_GT(with_wrong.loop_residual_sigmas[3], 30.0);
  for (size_t i = 0; i < 7; ++i) {
    if (i != 3) {
      EXPECT_LT(with_wrong.loop_residual_sigmas[i], 3.0) << "loop " << i;
    }
  }
  EXPECT_LT(deviation, 0.05);
  EXPECT_GT(deviation_least_squares, 1.0);
  EXPECT_LT(Ate(correct.world_from_node, graph.truth),
            0.8 * Ate(graph.odometry.world_from_node, graph.truth));
}

// Scale drift only: the odometry's unit grows by 0.5 % per 100 m, 5 % over
// a 1 km square. SE3 can only bend the trajectory to close the loop (its
// ATE gets worse than the odometry's); Sim3 shrinks it back.
TEST(PoseGraph, Sim3RecoversScaleDriftBetterThanSe3) {
  const std::vector<Rigid3d> truth = SquarePath(250, 1);
  const Odometry odometry = MakeOdometry(truth, 0.0, 5e-5);
  const int last = static_cast<int>(truth.size()) - 1;
  std::vector<PoseGraphEdge> edges = odometry.edges;
  edges.push_back(LoopEdge(truth, odometry, 0, last));

  PoseGraphOptions se3_options;
  PoseGraphOptions sim3_options;
  sim3_options.sim3 = true;
  const PoseGraphResult se3 = OptimizePoseGraph(odometry.world_from_node, edges, se3_options);
  const PoseGraphResult sim3 = OptimizePoseGraph(odometry.world_from_node, edges, sim3_options);
  ASSERT_TRUE(se3.ok && sim3.ok);

  // Each node's scale against the truth 1 / k.
  double scale_error_sum = 0.0;
  double scale_error_max = 0.0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const double error = std::abs(sim3.node_scale[i] * odometry.factor[i] - 1.0);
    scale_error_sum += error;
    scale_error_max = std::max(scale_error_max, error);
  }
  const double drift = odometry.factor.back() - 1.0;
  const double ate_odometry = Ate(odometry.world_from_node, truth);
  const double ate_se3 = Ate(se3.world_from_node, truth);
  const double ate_sim3 = Ate(sim3.world_from_node, truth);
  std::printf(
      "scale drift %.1f %% over 1 km: ATE odometry %.3f, SE3 %.3f, Sim3 %.3f m; end point %.3f / %.3f / "
      "%.3f m; Sim3 node scale error mean %.4f max %.4f; scale at the end %.4f (truth %.4f); loop "
      "residual SE3 %.2f, Sim3 %.2f sigmas\n",
      100.0 * drift, ate_odometry, ate_se3, ate_sim3, EndPointError(odometry.world_from_node, truth),
      EndPointError(se3.world_from_node, truth), EndPointError(sim3.world_from_node, truth),
      scale_error_sum / static_cast<double>(truth.size()), scale_error_max, sim3.node_scale.back(),
      1.0 / odometry.factor.back(), se3.loop_residual_sigmas[0], sim3.loop_residual_sigmas[0]);
  EXPECT_LT(ate_sim3, 0.25 * ate_se3);
  EXPECT_LT(ate_sim3, 0.25 * ate_odometry);
  EXPECT_LT(scale_error_max, 0.3 * drift);
  EXPECT_NEAR(sim3.node_scale.back(), 1.0 / odometry.factor.back(), 0.2 * drift);
  EXPECT_LT(sim3.loop_residual_sigmas[0], 3.0);
  EXPECT_EQ(sim3.node_scale[0], 1.0);
  for (double s : se3.node_scale) EXPECT_EQ(s, 1.0);
}

TEST(PoseGraph, SecondRunGivesIdenticalResults) {
  const TwoLaps graph;
  for (const bool sim3 : {false, true}) {
    PoseGraphOptions options;
    options.sim3 = sim3;
    const PoseGraphResult first =
        OptimizePoseGraph(graph.odometry.world_from_node, graph.Edges(true), options);
    const PoseGraphResult second =
        OptimizePoseGraph(graph.odometry.world_from_node, graph.Edges(true), options);
    ASSERT_TRUE(first.ok && second.ok);
    ExpectBitIdentical(first, second);
  }
}

// Nodes at 100, 200, ..., 500 ns; poses every 25 ns from 50 to 575 ns
// (before the first node, at nodes, between, after the last).
struct CorrectionCase {
  std::vector<int64_t> node_t_ns;
  std::vector<Rigid3d> node_before, node_after;
  std::vector<int64_t> pose_t_ns;
  std::vector<Rigid3d> poses_before;

  CorrectionCase() {
    const std::vector<Rigid3d> path = SquarePath(3, 2);  // 25 poses
    for (int k = 0; k < 5; ++k) {
      node_t_ns.push_back(100 * (k + 1));
      node_before.push_back(path[4 * k + 2]);
      node_after.emplace_back(Rpy(0.1 * k, -0.05 * k, 0.3 + 0.2 * k) * path[4 * k + 2].rotation,
                              path[4 * k + 2].translation + Eigen::Vector3d(0.5 * k, -0.3 * k, 0.1));
    }
    for (int k = 0; k < 22; ++k) {
      pose_t_ns.push_back(50 + 25 * k);
      // At node times, exactly the node's pose; elsewhere a pose of the path.
      poses_before.push_back(pose_t_ns.back() % 100 == 0 ? node_before[pose_t_ns.back() / 100 - 1] : path[k]);
    }
  }
  // Index of the node a pose at t belongs to.
  static int NodeOf(int64_t t) { return t < 100 ? 0 : static_cast<int>(std::min<int64_t>(t / 100, 5)) - 1; }
};

TEST(CorrectPoses, ExactAtNodesAndRigidlyRelativeInBetween) {
  const CorrectionCase c;
  const std::vector<Rigid3d> after =
      CorrectPoses(c.node_t_ns, c.node_before, c.node_after, c.pose_t_ns, c.poses_before);
  ASSERT_EQ(after.size(), c.poses_before.size());
  int at_nodes = 0;
  for (size_t p = 0; p < after.size(); ++p) {
    const int node = CorrectionCase::NodeOf(c.pose_t_ns[p]);
    if (c.pose_t_ns[p] % 100 == 0) {
      ++at_nodes;
      EXPECT_LT((after[p].translation - c.node_after[node].translation).norm(), 1e-12);
      EXPECT_LT(after[p].rotation.angularDistance(c.node_after[node].rotation), 1e-12);
    }
    const Rigid3d relative_before = c.node_before[node].Inverse() * c.poses_before[p];
    const Rigid3d relative_after = c.node_after[node].Inverse() * after[p];
    EXPECT_LT((relative_after.translation - relative_before.translation).norm(), 1e-12) << "pose " << p;
    EXPECT_LT(relative_after.rotation.angularDistance(relative_before.rotation), 1e-12) << "pose " << p;
    // Relative to its own node, not to the next one (when there is one).
    if (c.pose_t_ns[p] % 100 != 0 && node + 1 < 5 && c.pose_t_ns[p] > 100) {
      const Rigid3d other_before = c.node_before[node + 1].Inverse() * c.poses_before[p];
      const Rigid3d other_after = c.node_after[node + 1].Inverse() * after[p];
      EXPECT_GT((other_after.translation - other_before.translation).norm(), 1e-3) << "pose " << p;
    }
  }
  EXPECT_EQ(at_nodes, 5);
  // No nodes: unchanged.
  const std::vector<Rigid3d> unchanged = CorrectPoses({}, {}, {}, c.pose_t_ns, c.poses_before);
  for (size_t p = 0; p < unchanged.size(); ++p) {
    EXPECT_EQ(unchanged[p].translation, c.poses_before[p].translation);
  }
}

TEST(CorrectPoses, Sim3ScalesTheTranslationRelativeToTheNode) {
  const CorrectionCase c;
  const std::vector<double> scales = {1.0, 0.98, 1.03, 0.95, 1.1};
  const std::vector<Rigid3d> after =
      CorrectPoses(c.node_t_ns, c.node_before, c.node_after, scales, c.pose_t_ns, c.poses_before);
  for (size_t p = 0; p < after.size(); ++p) {
    const int node = CorrectionCase::NodeOf(c.pose_t_ns[p]);
    const Rigid3d relative_before = c.node_before[node].Inverse() * c.poses_before[p];
    const Rigid3d relative_after = c.node_after[node].Inverse() * after[p];
    EXPECT_LT((relative_after.translation - scales[node] * relative_before.translation).norm(), 1e-12);
    EXPECT_LT(relative_after.rotation.angularDistance(relative_before.rotation), 1e-12);
    if (c.pose_t_ns[p] % 100 == 0) {
      EXPECT_LT((after[p].translation - c.node_after[node].translation).norm(), 1e-12);
    }
  }
  // Scales of 1: the rigid correction, number for number.
  const std::vector<Rigid3d> rigid =
      CorrectPoses(c.node_t_ns, c.node_before, c.node_after, c.pose_t_ns, c.poses_before);
  const std::vector<Rigid3d> unit = CorrectPoses(c.node_t_ns, c.node_before, c.node_after,
                                                 std::vector<double>(5, 1.0), c.pose_t_ns, c.poses_before);
  for (size_t p = 0; p < rigid.size(); ++p) {
    EXPECT_EQ(rigid[p].translation, unit[p].translation);
    EXPECT_EQ(rigid[p].rotation.coeffs(), unit[p].rotation.coeffs());
  }
}

// Node k's prediction of a pose (CorrectPoses' rule, scale s).
Rigid3d CarriedByNode(const CorrectionCase& c, int k, double s, const Rigid3d& pose) {
  const Rigid3d relative = c.node_before[static_cast<size_t>(k)].Inverse() * pose;
  const Rigid3d& after = c.node_after[static_cast<size_t>(k)];
  return Rigid3d(after.rotation * relative.rotation, after.rotation * (s * relative.translation) + after.translation);
}

TEST(InterpolateCorrections, BlendsTheTwoNeighbouringNodesByTime) {
  const CorrectionCase c;
  const std::vector<double> scales = {1.0, 0.98, 1.03, 0.95, 1.1};
  const std::vector<int> one_segment(5, 0), pose_segments(c.pose_t_ns.size(), 0);
  const std::vector<Rigid3d> after = InterpolateCorrections(c.node_t_ns, one_segment, c.node_before, c.node_after,
                                                            scales, c.pose_t_ns, pose_segments, c.poses_before);
  ASSERT_EQ(after.size(), c.poses_before.size());
  for (size_t p = 0; p < after.size(); ++p) {
    SCOPED_TRACE(p);
    const int64_t t = c.pose_t_ns[p];
    if (t % 100 == 0) {  // at a node: exactly its after-pose
      const size_t node = static_cast<size_t>(t / 100 - 1);
      EXPECT_LT((after[p].translation - c.node_after[node].translation).norm(), 1e-12);
      EXPECT_LT(after[p].rotation.angularDistance(c.node_after[node].rotation), 1e-12);
    } else if (t < 100 || t > 500) {  // one side only: that node alone, with its scale
      const int node = t < 100 ? 0 : 4;
      const Rigid3d expected = CarriedByNode(c, node, scales[static_cast<size_t>(node)], c.poses_before[p]);
      EXPECT_LT((after[p].translation - expected.translation).norm(), 1e-12);
      EXPECT_LT(after[p].rotation.angularDistance(expected.rotation), 1e-12);
    } else {  // between nodes a and a + 1: the blend, both with a's scale
      const int a = static_cast<int>(t / 100) - 1;
      const double tau = static_cast<double>(t - c.node_t_ns[static_cast<size_t>(a)]) / 100.0;
      const double s = scales[static_cast<size_t>(a)];
      const Rigid3d from_a = CarriedByNode(c, a, s, c.poses_before[p]);
      const Rigid3d from_b = CarriedByNode(c, a + 1, s, c.poses_before[p]);
      EXPECT_LT((after[p].translation - ((1 - tau) * from_a.translation + tau * from_b.translation)).norm(), 1e-12);
      EXPECT_LT(after[p].rotation.angularDistance(from_a.rotation.slerp(tau, from_b.rotation)), 1e-12);
      // Strictly between the two predictions when they differ.
      const double gap = (from_a.translation - from_b.translation).norm();
      ASSERT_GT(gap, 1e-3);
      EXPECT_NEAR((after[p].translation - from_a.translation).norm(), tau * gap, 1e-9);
    }
  }
  // Continuous at a node: a pose 1 ns before node 3 (t 400) that equals
  // node 3's before-pose lands within 1 % (tau 0.99) of the way to node 2's
  // prediction, where CorrectPoses (node 2 alone) puts it.
  const std::vector<Rigid3d> near = InterpolateCorrections(c.node_t_ns, one_segment, c.node_before, c.node_after,
                                                           scales, {399}, {0}, {c.node_before[3]});
  const std::vector<Rigid3d> jump =
      CorrectPoses(c.node_t_ns, c.node_before, c.node_after, scales, {399}, {c.node_before[3]});
  const double jump_m = (jump[0].translation - c.node_after[3].translation).norm();
  ASSERT_GT(jump_m, 0.1);
  EXPECT_NEAR((near[0].translation - c.node_after[3].translation).norm(), 0.01 * jump_m, 1e-9);
}

TEST(InterpolateCorrections, TheSameCorrectionEverywhereMovesEveryPoseByIt) {
  CorrectionCase c;
  const Rigid3d correction(Rpy(0.2, -0.1, 0.4), Eigen::Vector3d(1.0, -2.0, 0.5));
  for (size_t k = 0; k < c.node_after.size(); ++k) c.node_after[k] = correction * c.node_before[k];
  const std::vector<Rigid3d> after =
      InterpolateCorrections(c.node_t_ns, std::vector<int>(5, 0), c.node_before, c.node_after,
                             std::vector<double>(5, 1.0), c.pose_t_ns, std::vector<int>(c.pose_t_ns.size(), 0),
                             c.poses_before);
  for (size_t p = 0; p < after.size(); ++p) {
    const Rigid3d expected = correction * c.poses_before[p];
    EXPECT_LT((after[p].translation - expected.translation).norm(), 1e-12) << p;
    EXPECT_LT(after[p].rotation.angularDistance(expected.rotation), 1e-12) << p;
  }
}

TEST(InterpolateCorrections, NeverBlendsAcrossSegments) {
  const CorrectionCase c;
  // Nodes 0, 1 in segment 0, nodes 2-4 in segment 1. Poses at 250 (between
  // nodes 1 and 2): of segment 0, node 1 alone (no later node of its
  // segment); of segment 1, node 2 alone (no earlier one); of a segment
  // without nodes, the latest node at or before it (CorrectPoses).
  const std::vector<int> node_segment = {0, 0, 1, 1, 1};
  const std::vector<double> scales(5, 1.0);
  const Rigid3d pose = c.poses_before[8];  // t = 250 in the fixture
  const std::vector<Rigid3d> after = InterpolateCorrections(c.node_t_ns, node_segment, c.node_before, c.node_after,
                                                            scales, {250, 250, 250}, {0, 1, 7}, {pose, pose, pose});
  const Rigid3d by_1 = CarriedByNode(c, 1, 1.0, pose), by_2 = CarriedByNode(c, 2, 1.0, pose);
  EXPECT_LT((after[0].translation - by_1.translation).norm(), 1e-12);
  EXPECT_LT((after[1].translation - by_2.translation).norm(), 1e-12);
  EXPECT_LT((after[2].translation - by_1.translation).norm(), 1e-12);
  EXPECT_GT((by_1.translation - by_2.translation).norm(), 1e-3);
}

TEST(PoseGraphOptions, CheckNamesTheField) {
  EXPECT_NO_THROW(PoseGraphOptions().Check());
  struct Case {
    const char* field;
    void (*spoil)(PoseGraphOptions*);
  };
  const Case cases[] = {
      {"odometry_rotation_sigma_deg_per_m",
       [](PoseGraphOptions* o) { o->odometry_rotation_sigma_deg_per_m = -1; }},
      {"odometry_translation_sigma_per_m",
       [](PoseGraphOptions* o) { o->odometry_translation_sigma_per_m = -0.1; }},
      {"odometry_rotation_sigma_floor_deg",
       [](PoseGraphOptions* o) { o->odometry_rotation_sigma_floor_deg = 0; }},
      {"odometry_translation_sigma_floor_m",
       [](PoseGraphOptions* o) { o->odometry_translation_sigma_floor_m = 0; }},
      {"odometry_scale_sigma_per_m", [](PoseGraphOptions* o) { o->odometry_scale_sigma_per_m = -1e-3; }},
      {"odometry_scale_sigma_floor", [](PoseGraphOptions* o) { o->odometry_scale_sigma_floor = 0; }},
      {"loop_rotation_sigma_deg", [](PoseGraphOptions* o) { o->loop_rotation_sigma_deg = 0; }},
      {"loop_translation_sigma_m", [](PoseGraphOptions* o) { o->loop_translation_sigma_m = -1; }},
      {"loop_scale_sigma", [](PoseGraphOptions* o) { o->loop_scale_sigma = 0; }},
      {"loop_loss_scale", [](PoseGraphOptions* o) { o->loop_loss_scale = 0; }},
      {"loop_loss_stages", [](PoseGraphOptions* o) { o->loop_loss_stages = 0; }},
      {"loop_loss_stage_factor", [](PoseGraphOptions* o) { o->loop_loss_stage_factor = 0.5; }},
      {"max_iterations", [](PoseGraphOptions* o) { o->max_iterations = 0; }},
      {"loop_translation_sigma_m", [](PoseGraphOptions* o) { o->loop_translation_sigma_m = std::nan(""); }},
  };
  for (const Case& c : cases) {
    PoseGraphOptions options;
    c.spoil(&options);
    try {
      options.Check();
      ADD_FAILURE() << c.field << ": no error";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("/loop/pose_graph/") + c.field), std::string::npos)
          << e.what();
    }
  }
  // OptimizePoseGraph checks its options.
  PoseGraphOptions bad;
  bad.loop_loss_scale = -1.0;
  EXPECT_THROW(OptimizePoseGraph({Rigid3d(), Rigid3d()}, {}, bad), InputError);
}

// 2000 nodes (five laps of a 400 m square), 20 loops from laps 2-5 to the
// first: both graphs at least halve the odometry's ATE. The time is printed
// for information only, never asserted (tools/bench_loop.sh measures speed).
TEST(PoseGraph, TwentyLoopsOver2000Nodes) {
  const std::vector<Rigid3d> truth = SquarePath(100, 5);
  const Odometry odometry = MakeOdometry(truth, 0.003, 2e-5);
  std::vector<PoseGraphEdge> edges = odometry.edges;
  for (int lap = 1; lap < 5; ++lap) {
    for (int k : {0, 70, 150, 230, 320}) edges.push_back(LoopEdge(truth, odometry, k, 400 * lap + k));
  }
  ASSERT_EQ(edges.size(), odometry.edges.size() + 20);
  for (const bool sim3 : {false, true}) {
    PoseGraphOptions options;
    options.sim3 = sim3;
    const auto start = std::chrono::steady_clock::now();
    const PoseGraphResult result = OptimizePoseGraph(odometry.world_from_node, edges, options);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_TRUE(result.ok) << result.reason;
    double worst_loop = 0.0;
    for (double r : result.loop_residual_sigmas) worst_loop = std::max(worst_loop, r);
    std::printf(
        "%s, %zu nodes, %zu edges (20 loops): %.3f s, %d iterations, ATE %.3f -> %.3f m, worst loop "
        "%.2f sigmas\n",
        sim3 ? "Sim3" : "SE3", truth.size(), edges.size(), seconds, result.iterations,
        Ate(odometry.world_from_node, truth), Ate(result.world_from_node, truth), worst_loop);
    EXPECT_LT(Ate(result.world_from_node, truth), 0.5 * Ate(odometry.world_from_node, truth));
  }
}

}  // namespace
}  // namespace mcvo
