// Inverse compositional affine alignment of a feature's anchor patch
// (patch_aligner.h).
#include "mcvo/frontend/patch_aligner.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace mcvo {
namespace {

// Samples the (2 h + 1)^2 template grid warped by y = warp * x + centre,
// row-major; false when a sample leaves the image. Each sample position is
// (warp(i, 0) u + warp(i, 1) v) + centre(i), the operations of the Eigen
// expression in its order, with the products of the column's u computed
// once per call instead of once per sample.
bool SampleWarped(const cv::Mat& image, const Eigen::Matrix2f& warp, const Eigen::Vector2f& centre, int h,
                  Eigen::VectorXf* values) {
  if (image.cols < 2 || image.rows < 2) return false;  // no bilinear cell
  const int side = 2 * h + 1;
  values->resize(side * side);
  thread_local std::vector<float> ux, uy;  // warp(0, 0) u, warp(1, 0) u
  ux.resize(static_cast<size_t>(side));
  uy.resize(static_cast<size_t>(side));
  for (int u = -h; u <= h; ++u) {
    ux[static_cast<size_t>(u + h)] = warp(0, 0) * static_cast<float>(u);
    uy[static_cast<size_t>(u + h)] = warp(1, 0) * static_cast<float>(u);
  }
  const float max_x = static_cast<float>(image.cols - 1), max_y = static_cast<float>(image.rows - 1);
  const uint8_t* data = image.data;
  const size_t step = image.step[0];
  float* out = values->data();
  for (int v = -h; v <= h; ++v) {
    const float vx = warp(0, 1) * static_cast<float>(v), vy = warp(1, 1) * static_cast<float>(v);
    for (int i = 0; i < side; ++i) {
      const float x = ux[static_cast<size_t>(i)] + vx + centre.x();
      const float y = uy[static_cast<size_t>(i)] + vy + centre.y();
      if (!(x >= 0.0f && y >= 0.0f && x <= max_x && y <= max_y)) return false;
      // Bilinear; x0, y0 kept so that x0 + 1, y0 + 1 are in the image.
      const int x0 = std::min(static_cast<int>(x), image.cols - 2);
      const int y0 = std::min(static_cast<int>(y), image.rows - 2);
      const float ax = x - static_cast<float>(x0);
      const float ay = y - static_cast<float>(y0);
      const uint8_t* r0 = data + static_cast<size_t>(y0) * step + x0;
      const uint8_t* r1 = r0 + step;
      const float top = static_cast<float>(r0[0]) + ax * (static_cast<float>(r0[1]) - static_cast<float>(r0[0]));
      const float bottom = static_cast<float>(r1[0]) + ax * (static_cast<float>(r1[1]) - static_cast<float>(r1[0]));
      *out++ = top + ay * (bottom - top);
    }
  }
  return true;
}

// Zero mean, unit norm in place; returns the norm it divided by, 0 when the
// patch is flat (an rms deviation under half a grey level; values then
// zero-mean only).
float Normalise(Eigen::VectorXf* values) {
  const float mean = values->mean();
  values->array() -= mean;
  const float norm = values->norm();
  if (!(norm > 0.5f * std::sqrt(static_cast<float>(values->size())))) return 0.0f;
  *values /= norm;
  return norm;
}

}  // namespace

PatchAnchor MakePatchAnchor(const cv::Mat& image, const Eigen::Vector2f& pixel, const PatchAlignOptions& options) {
  PatchAnchor anchor;
  const int h = options.half_size_px;
  const int side = 2 * h + 1;
  // One pixel more on every side for the central differences.
  Eigen::VectorXf wide;
  if (!SampleWarped(image, Eigen::Matrix2f::Identity(), pixel, h + 1, &wide)) return anchor;
  // Normalise with the template's own statistics (the inner grid), applied
  // to the wide grid so that the gradients are of the normalised template.
  const int wide_side = side + 2;
  Eigen::VectorXf inner(side * side);
  for (int r = 0; r < side; ++r) inner.segment(r * side, side) = wide.segment((r + 1) * wide_side + 1, side);
  const float norm = Normalise(&inner);
  if (norm == 0.0f) return anchor;
  anchor.values = std::move(inner);
  anchor.steepest.resize(side * side, 6);
  int k = 0;
  for (int v = -h; v <= h; ++v) {
    for (int u = -h; u <= h; ++u, ++k) {
      const int r = v + h + 1;
      const int c = u + h + 1;
      const float gx = 0.5f * (wide[r * wide_side + c + 1] - wide[r * wide_side + c - 1]) / norm;
      const float gy = 0.5f * (wide[(r + 1) * wide_side + c] - wide[(r - 1) * wide_side + c]) / norm;
      const float fu = static_cast<float>(u);
      const float fv = static_cast<float>(v);
      anchor.steepest.row(k) << gx * fu, gx * fv, gy * fu, gy * fv, gx, gy;
    }
  }
  // Gaussian weights (weight_sigma_px): the Gauss-Newton step minimises
  // sum w (I - T)^2, so the steepest-descent rows kept are w-scaled and the
  // Hessian is SD^T W SD.
  Eigen::Matrix<float, Eigen::Dynamic, 6> weighted = anchor.steepest;
  anchor.weights = Eigen::VectorXf::Ones(side * side);
  if (options.weight_sigma_px > 0.0) {
    const float two_sigma2 = static_cast<float>(2.0 * options.weight_sigma_px * options.weight_sigma_px);
    int row = 0;
    for (int v = -h; v <= h; ++v) {
      for (int u = -h; u <= h; ++u, ++row) {
        anchor.weights[row] = std::exp(-static_cast<float>(u * u + v * v) / two_sigma2);
        weighted.row(row) *= anchor.weights[row];
      }
    }
  }
  const Eigen::Matrix<double, 6, 6> hessian = (anchor.steepest.transpose() * weighted).cast<double>();
  anchor.steepest = std::move(weighted);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(hessian);
  const double largest = eigen.eigenvalues()(5);
  // The translation block carries the feature's position: it must be well
  // conditioned by itself (an edge is not a feature).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> translation(hessian.bottomRightCorner<2, 2>());
  if (!(largest > 0.0) || eigen.eigenvalues()(0) < 1e-7 * largest ||
      translation.eigenvalues()(0) < 1e-2 * translation.eigenvalues()(1)) {
    return anchor;
  }
  anchor.hessian_inverse = hessian.inverse().cast<float>();
  anchor.valid = true;
  return anchor;
}

PatchAlignResult AlignPatch(const PatchAnchor& anchor, const cv::Mat& image, const Eigen::Vector2f& initial_pixel,
                            const PatchAlignOptions& options) {
  PatchAlignResult result;
  if (!anchor.valid) return result;
  const int h = options.half_size_px;
  Eigen::Matrix2f warp = anchor.warp;
  Eigen::Vector2f centre = initial_pixel;
  Eigen::VectorXf values;
  // Gauss-Newton with step halving: a step that raises the weighted cost is
  // taken back and tried at half length (textures where the linearisation
  // overshoots would otherwise oscillate).
  Eigen::Matrix2f accepted_warp = warp;
  Eigen::Vector2f accepted_centre = centre;
  Eigen::Matrix<float, 6, 1> step = Eigen::Matrix<float, 6, 1>::Zero();
  float accepted_cost = std::numeric_limits<float>::infinity();
  float length = 1.0f;
  bool converged = false;
  float moved = 0.0f;
  for (int it = 0; it < options.max_iterations; ++it) {
    result.iterations = it + 1;
    if (!SampleWarped(image, warp, centre, h, &values)) {
      result.status = PatchAlignStatus::kOutsideImage;
      return result;
    }
    if (Normalise(&values) == 0.0f) return result;
    const Eigen::VectorXf error = values - anchor.values;
    const float cost = error.cwiseAbs2().dot(anchor.weights);
    if (cost <= accepted_cost) {
      accepted_cost = cost;
      accepted_warp = warp;
      accepted_centre = centre;
      step = anchor.hessian_inverse * (anchor.steepest.transpose() * error);
      length = 1.0f;
    } else {
      // Back to the last accepted state, half the step.
      warp = accepted_warp;
      centre = accepted_centre;
      length *= 0.5f;
    }
    const Eigen::Matrix<float, 6, 1> scaled = length * step;
    // Inverse composition: W <- W o W(step)^-1, W(step): x -> (I + D) x + d.
    Eigen::Matrix2f identity_plus_d;
    identity_plus_d << 1.0f + scaled[0], scaled[1], scaled[2], 1.0f + scaled[3];
    const float det = identity_plus_d.determinant();
    if (!(std::abs(det) > 1e-3f)) return result;
    const Eigen::Matrix2f new_warp = warp * identity_plus_d.inverse();
    const Eigen::Vector2f new_centre = centre - new_warp * scaled.tail<2>();
    moved = (new_centre - centre).norm();
    result.last_step_px = static_cast<double>(moved);
    if (!std::isfinite(moved)) return result;
    if (moved < static_cast<float>(options.convergence_px)) {
      // The state the step starts from is the estimate (the tiny step is
      // not checked against the cost).
      converged = true;
      break;
    }
    warp = new_warp;
    centre = new_centre;
  }
  // Not converged within max_iterations: accepted when the last step was
  // still small (a slow approach), not when it oscillates.
  if (!converged && !(moved < 10.0f * static_cast<float>(options.convergence_px))) return result;
  if (!SampleWarped(image, warp, centre, h, &values)) {
    result.status = PatchAlignStatus::kOutsideImage;
    return result;
  }
  if (Normalise(&values) == 0.0f) return result;
  result.zncc = static_cast<double>(values.dot(anchor.values));
  result.pixel = centre;
  result.warp = warp;
  const bool near_lk = static_cast<double>((centre - initial_pixel).norm()) <= options.max_shift_px;
  const float initial_det = anchor.warp.determinant();
  const bool small_change =
      std::abs(initial_det) > 1e-6f && !WarpBeyond(warp * anchor.warp.inverse(), options.max_warp_change);
  if (result.zncc >= options.min_zncc && near_lk && small_change) result.status = PatchAlignStatus::kAligned;
  return result;
}

bool WarpBeyond(const Eigen::Matrix2f& warp, double scale) {
  const Eigen::JacobiSVD<Eigen::Matrix2f> svd(warp);
  return static_cast<double>(svd.singularValues()(0)) > scale ||
         static_cast<double>(svd.singularValues()(1)) < 1.0 / scale;
}

}  // namespace mcvo
