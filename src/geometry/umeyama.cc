#include "mcvo/geometry/umeyama.h"

#include <cmath>

#include <Eigen/SVD>

namespace mcvo {
namespace {

// Relative size of the second singular value of the cross-covariance below
// which the points are treated as collinear (noise-free collinear input gives
// ~1e-16; a real trajectory that is merely straight gives far more).
constexpr double kCollinearRatio = 1e-10;

bool AllFinite(const std::vector<Eigen::Vector3d>& points) {
  for (const Eigen::Vector3d& p : points) {
    if (!p.allFinite()) return false;
  }
  return true;
}

Eigen::Vector3d Mean(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) sum += p;
  return sum / static_cast<double>(points.size());
}

}  // namespace

std::optional<Sim3d> AlignUmeyama(const std::vector<Eigen::Vector3d>& src,
                                  const std::vector<Eigen::Vector3d>& dst, bool estimate_scale,
                                  UmeyamaInfo* info) {
  if (info != nullptr) *info = UmeyamaInfo();
  if (src.size() != dst.size() || src.size() < 2 || !AllFinite(src) || !AllFinite(dst)) return std::nullopt;
  const double n = static_cast<double>(src.size());
  const Eigen::Vector3d mu_s = Mean(src);
  const Eigen::Vector3d mu_d = Mean(dst);
  double var_s = 0.0;
  double var_d = 0.0;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();  // 1/n sum (d - mu_d)(s - mu_s)^T
  for (size_t i = 0; i < src.size(); ++i) {
    const Eigen::Vector3d s = src[i] - mu_s;
    const Eigen::Vector3d d = dst[i] - mu_d;
    var_s += s.squaredNorm();
    var_d += d.squaredNorm();
    cov += d * s.transpose();
  }
  var_s /= n;
  var_d /= n;
  cov /= n;
  if (!(var_s > 0.0) || !(var_d > 0.0)) return std::nullopt;

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d& sigma = svd.singularValues();  // decreasing, >= 0
  if (!(sigma(0) > 0.0)) return std::nullopt;
  const Eigen::Matrix3d& u = svd.matrixU();
  const Eigen::Matrix3d& v = svd.matrixV();

  Eigen::Matrix3d rotation;
  double trace_ds;
  if (sigma(1) <= kCollinearRatio * sigma(0)) {
    // Rank 1: C = sigma0 u0 v0^T; trace(R^T C) = sigma0 u0^T R v0 is maximal
    // for any R with R v0 = u0. Take the smallest such rotation.
    if (info != nullptr) info->collinear = true;
    rotation = Eigen::Quaterniond::FromTwoVectors(v.col(0), u.col(0)).toRotationMatrix();
    trace_ds = sigma(0);
  } else {
    Eigen::Vector3d s_diag(1.0, 1.0, 1.0);
    if (u.determinant() * v.determinant() < 0.0) s_diag(2) = -1.0;
    rotation = u * s_diag.asDiagonal() * v.transpose();
    trace_ds = sigma.dot(s_diag);
  }
  const double scale = estimate_scale ? trace_ds / var_s : 1.0;
  if (!(scale > 0.0) || !std::isfinite(scale)) return std::nullopt;
  const Eigen::Quaterniond q(rotation);
  return Sim3d(scale, q, mu_d - scale * (q.normalized() * mu_s));
}

std::optional<Sim3d> AlignPosYaw(const std::vector<Eigen::Vector3d>& src,
                                 const std::vector<Eigen::Vector3d>& dst) {
  if (src.size() != dst.size() || src.size() < 2 || !AllFinite(src) || !AllFinite(dst)) return std::nullopt;
  const Eigen::Vector3d mu_s = Mean(src);
  const Eigen::Vector3d mu_d = Mean(dst);
  double horizontal_s = 0.0;
  double horizontal_d = 0.0;
  double sin_sum = 0.0;  // sum s'_x d'_y - s'_y d'_x
  double cos_sum = 0.0;  // sum s'_x d'_x + s'_y d'_y
  for (size_t i = 0; i < src.size(); ++i) {
    const Eigen::Vector3d s = src[i] - mu_s;
    const Eigen::Vector3d d = dst[i] - mu_d;
    horizontal_s += s.head<2>().squaredNorm();
    horizontal_d += d.head<2>().squaredNorm();
    sin_sum += s.x() * d.y() - s.y() * d.x();
    cos_sum += s.x() * d.x() + s.y() * d.y();
  }
  if (!(horizontal_s > 0.0) || !(horizontal_d > 0.0)) return std::nullopt;
  // Derivation: the cost's yaw-dependent part is -sum d'^T Rz s' =
  // -(cos_sum cos(yaw) + sin_sum sin(yaw)), minimal at yaw = atan2(sin_sum, cos_sum).
  const double yaw = std::atan2(sin_sum, cos_sum);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return Sim3d(1.0, q, mu_d - q * mu_s);
}

}  // namespace mcvo
