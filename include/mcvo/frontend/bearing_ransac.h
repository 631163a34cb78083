// Outlier rejection between two views of one central camera by RANSAC on unit
// bearing vectors (Camera::Unproject), so it works for every camera model,
// fisheyes beyond 90 degrees included (no pinhole projection involved).
//
// Models (OpenGV, deterministic: each problem owns an mt19937 seeded with a
// fixed value when randomSeed = false, so the result depends only on the
// input, never on time or on other threads):
//  * the 5-point relative pose (Stewenius et al. 2006, the essential matrix
//    on bearings), OpenGV CentralRelativePoseSacProblem;
//  * the 2-point rotation-only model (Arun et al. 1987), OpenGV
//    RotationOnlySacProblem, for a camera that barely translated: there the
//    essential matrix is degenerate (triangulation of the inliers fails), and
//    the rotation explains every inlier within the threshold.
// The model with more inliers wins (ties: the 5-point model).
//
// Error of a correspondence (OpenGV's): 1 - cos of the angle between an
// observed bearing and the reprojection of the triangulated point, summed over
// both views (5-point), or 1 - cos(angle(R * f_cur, f_prev)) (rotation only).
// A pixel threshold e at a virtual pinhole focal f (reference: 1 px at 460 px)
// is the angle atan(e / f): BearingThresholdFromPixels.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

namespace mcvo {

// 1 - cos(atan(threshold_px / focal_px)): OpenGV's threshold for an angular
// error of threshold_px pixels on a pinhole of focal focal_px.
double BearingThresholdFromPixels(double threshold_px, double focal_px);

struct BearingRansacOptions {
  double threshold = BearingThresholdFromPixels(1.0, 460.0);  // 1 - cos(angle), see above
  // Upper bound on the hypotheses per model (OpenGV stops earlier once the
  // probability 0.99 of having drawn an all-inlier sample is reached). 200
  // 5-point samples find an all-inlier sample with 99.99 % probability at 50 %
  // outliers (1 - (1 - 0.5^5)^200).
  int max_iterations = 200;
  // Fewer correspondences than this: no test, every one is kept (5 points fit
  // any 5 correspondences; 8 is the smallest set with some redundancy).
  int min_correspondences = 8;
};

// inliers[i] tells whether correspondence i (bearings_prev[i] <-> bearings_cur[i],
// unit vectors, same size) fits the winning model. Deterministic.
std::vector<bool> RansacRelativePoseInliers(const std::vector<Eigen::Vector3d>& bearings_prev,
                                            const std::vector<Eigen::Vector3d>& bearings_cur,
                                            const BearingRansacOptions& options);

// The signature of the brief: threshold as the angle itself (radians).
std::vector<bool> RansacRelativePoseInliers(const std::vector<Eigen::Vector3d>& bearings_prev,
                                            const std::vector<Eigen::Vector3d>& bearings_cur,
                                            double threshold_angle_rad, int max_iterations);

// The rotation R minimising sum |cur_i - R prev_i|^2 over unit bearings
// (Kabsch / Arun: SVD of sum cur_i prev_i^T, determinant fixed to +1).
// With translation the fit also takes up the part of the flow a rotation
// explains; as a prediction of the next frame's flow that is what is wanted.
// Nullopt for fewer than 3 pairs or a degenerate (rank < 2) set.
std::optional<Eigen::Matrix3d> FitBearingRotation(const std::vector<Eigen::Vector3d>& prev,
                                                  const std::vector<Eigen::Vector3d>& cur);

}  // namespace mcvo
