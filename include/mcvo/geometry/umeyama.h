// Closed-form alignment of corresponding point sets.
//
// Given src[i] <-> dst[i], find dst_from_src minimising
//   sum_i |dst[i] - (s R src[i] + t)|^2
// (Umeyama, "Least-squares estimation of transformation parameters between
// two point patterns", PAMI 1991, eq. 40-42):
//   mu_s, mu_d           means;  var_s = 1/n sum |src[i] - mu_s|^2
//   C = 1/n sum (dst[i] - mu_d)(src[i] - mu_s)^T = U D V^T   (SVD)
//   S = diag(1, 1, det(U) det(V))                   (no reflection)
//   R = U S V^T,  s = trace(D S) / var_s (or 1),  t = mu_d - s R mu_s.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "mcvo/geometry/sim3d.h"

namespace mcvo {

struct UmeyamaInfo {
  // True when the source or destination points are collinear (rank(C) = 1):
  // the rotation about the line is then not observable. The documented
  // fallback keeps Umeyama's rotation restricted to the observable part: the
  // smallest rotation that takes the source line direction onto the
  // destination line direction (no twist about the line). Positions are
  // aligned exactly as well as any least-squares solution aligns them.
  bool collinear = false;
};

// Returns dst_from_src (scale exactly 1 when estimate_scale is false).
// std::nullopt when the sizes differ, fewer than 2 points are given, a
// point is not finite, or all source (or all destination) points coincide.
std::optional<Sim3d> AlignUmeyama(const std::vector<Eigen::Vector3d>& src,
                                  const std::vector<Eigen::Vector3d>& dst, bool estimate_scale,
                                  UmeyamaInfo* info = nullptr);

// Translation + rotation about the z axis only (scale 1): the "posyaw"
// alignment of visual-inertial odometry, where gravity fixes roll and pitch.
// Minimising sum |d_i - Rz(yaw) s_i - t|^2 over (yaw, t) with centred points
// s', d' gives (the z components do not depend on yaw)
//   yaw = atan2(sum (s'_x d'_y - s'_y d'_x), sum (s'_x d'_x + s'_y d'_y)),
//   t   = mu_d - Rz(yaw) mu_s.
// std::nullopt when the sizes differ, fewer than 2 points are given, a point
// is not finite, or the horizontal (x, y) extent of src or dst is zero (yaw
// not observable).
std::optional<Sim3d> AlignPosYaw(const std::vector<Eigen::Vector3d>& src,
                                 const std::vector<Eigen::Vector3d>& dst);

}  // namespace mcvo
