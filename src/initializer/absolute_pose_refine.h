// Refinement of one camera's absolute pose on fixed points: the window SfM's
// step after P3P RANSAC (camera_sfm.cc). Internal to the module.
#pragma once

#include <vector>

#include <opengv/types.hpp>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo::initializer_internal {

// world_from_cam refined from `start` on the observations `rows` of `points`
// (world coordinates, held fixed) at `bearings` (camera frame, unit): least
// squares of the tangent-plane bearing error in pixels at `focal`
// (TangentBearingCost, the error the window's BA minimises), Levenberg-
// Marquardt on Ceres with analytic Jacobians, dense QR, at most
// `max_iterations`, single-threaded (deterministic). No robust loss: the rows
// are RANSAC's inliers. Replaces OpenGV's optimizeModelCoefficients, whose
// Levenberg-Marquardt differentiates numerically and minimises 1 - cos.
// Returns `start` unchanged when `rows` is empty.
Rigid3d RefineAbsolutePose(const opengv::bearingVectors_t& bearings, const opengv::points_t& points,
                           const std::vector<int>& rows, double focal, const Rigid3d& start,
                           int max_iterations = 10);

}  // namespace mcvo::initializer_internal
