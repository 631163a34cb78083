// Camera models as value types with static functions templated on the scalar,
// so that ceres::Jet passes through Project/Unproject: a Ceres AutoDiff cost
// functor calls Model::Project<T>(params, point_in_cam, pixel) directly, and
// run-time code chooses the model once with VisitCameraModel.
//
// Every model has the same interface:
//
//   static constexpr CameraModelId kId;
//   static constexpr std::string_view kName;  // rig.json name
//   static constexpr int kNumParams;
//   // Pixels per radian at the principal point (mean of u and v).
//   static double MeanFocalLength(const double* params);
//   // "" when the parameters are usable, else what is wrong with them.
//   static std::string_view ParamsError(const double* params);
//   // True when the point (camera frame) is inside the valid domain, where
//   // Project succeeds and Unproject(Project(p)) = p / |p|.
//   static bool IsInDomain(const double* params, const double* point_in_cam);
//   template <typename T>
//   static bool Project(const T* params, const T* point_in_cam /*3*/, T* pixel /*2*/);
//   // As Project in double; jacobian = d(pixel)/d(point_in_cam), 2x3
//   // row-major, may be null. Analytic for all five models.
//   static bool ProjectWithJacobian(const double* params, const double* point_in_cam,
//                                   double* pixel, double* jacobian);
//   // Unit-norm bearing of a pixel; false when the pixel is outside the image
//   // of the valid domain or the iterative inverse does not converge.
//   template <typename T>
//   static bool Unproject(const T* params, const T* pixel /*2*/, T* bearing /*3*/);
//
// Pixels: OpenCV's convention, the centre of the top-left pixel is (0, 0).
// Project does not test the image rectangle (Camera::IsInImage does).
//
// Jets. Domain tests are decided on the scalar parts (ScalarPart), never on
// derivatives, so a Jet's derivative is that of the smooth branch its value is
// on. Iterative inverses (Unproject of radtan, KB, MEI) iterate on doubles and
// finish with one Newton step in T, which yields the derivatives of the
// implicit function. The 0/0 of KB on the optical axis is replaced by its
// first-order limit, so no NaN reaches a Jet.
#pragma once

#include <cmath>
#include <string_view>

#include "mcvo/camera/camera.h"
#include "mcvo/camera/distortion.h"
#include "mcvo/camera/scalar.h"
#include "mcvo/util/error.h"

namespace mcvo {

// Smallest cosine between the optical axis and a point that pinhole and
// radtan accept (the point is at most ~89.99994 degrees off axis).
inline constexpr double kMinPerspectiveCos = 1e-6;

namespace camera_internal {

// Runs a double domain test on the scalar parts of T arrays.
template <int kNumParams, typename T>
bool IsInDomainOfScalars(const T* params, const T* point, bool (*test)(const double*, const double*)) {
  double params_scalar[kNumParams];
  for (int i = 0; i < kNumParams; ++i) params_scalar[i] = ScalarPart(params[i]);
  const double point_scalar[3] = {ScalarPart(point[0]), ScalarPart(point[1]), ScalarPart(point[2])};
  return test(params_scalar, point_scalar);
}

template <typename T>
void NormalizeInto(const T& x, const T& y, const T& z, T* bearing) {
  using std::sqrt;
  const T inv_norm = T(1.0) / sqrt(x * x + y * y + z * z);
  bearing[0] = x * inv_norm;
  bearing[1] = y * inv_norm;
  bearing[2] = z * inv_norm;
}

}  // namespace camera_internal

// ---------------------------------------------------------------------------
// Pinhole. params: fx fy cx cy.
//   u = fx X/Z + cx,  v = fy Y/Z + cy.
// Domain: Z > kMinPerspectiveCos |P|. Unproject: closed form, every pixel.
struct PinholeModel {
  static constexpr CameraModelId kId = CameraModelId::kPinhole;
  static constexpr std::string_view kName = "pinhole";
  static constexpr int kNumParams = 4;

  // Pixels per radian at the principal point, mean of the two axes.
  static double MeanFocalLength(const double* p) { return 0.5 * (p[0] + p[1]); }
  static std::string_view ParamsError(const double* params);
  static bool IsInDomain(const double* params, const double* point);
  static bool ProjectWithJacobian(const double* params, const double* point, double* pixel, double* jacobian);

  template <typename T>
  static bool Project(const T* params, const T* point, T* pixel) {
    if (!camera_internal::IsInDomainOfScalars<kNumParams>(params, point, &IsInDomain)) return false;
    pixel[0] = params[0] * point[0] / point[2] + params[2];
    pixel[1] = params[1] * point[1] / point[2] + params[3];
    return true;
  }

  template <typename T>
  static bool Unproject(const T* params, const T* pixel, T* bearing) {
    if (!std::isfinite(ScalarPart(pixel[0])) || !std::isfinite(ScalarPart(pixel[1]))) return false;
    camera_internal::NormalizeInto((pixel[0] - params[2]) / params[0], (pixel[1] - params[3]) / params[1],
                                   T(1.0), bearing);
    return true;
  }
};

// ---------------------------------------------------------------------------
// Radial-tangential (OpenCV's cv::projectPoints model).
// params: fx fy cx cy k1 k2 p1 p2 k3 (distortion in OpenCV's order).
//   (x, y) = (X/Z, Y/Z),  (xd, yd) = distort(x, y) (camera/distortion.h),
//   u = fx xd + cx,  v = fy yd + cy.
// Domain: as pinhole, and x^2 + y^2 below the first positive root of
// 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3, where r_d(r) stops being monotonic.
// Unproject: damped Newton inside that radius.
struct RadTanModel {
  static constexpr CameraModelId kId = CameraModelId::kRadTan;
  static constexpr std::string_view kName = "radtan";
  static constexpr int kNumParams = 9;

  // Pixels per radian at the principal point, mean of the two axes.
  static double MeanFocalLength(const double* p) { return 0.5 * (p[0] + p[1]); }
  static std::string_view ParamsError(const double* params);
  static bool IsInDomain(const double* params, const double* point);
  static bool ProjectWithJacobian(const double* params, const double* point, double* pixel, double* jacobian);
  // Normalised distorted (xd, yd) -> undistorted (x, y), inside the domain.
  static bool Undistort(const double* params, double xd, double yd, double* x, double* y);

  template <typename T>
  static bool Project(const T* params, const T* point, T* pixel) {
    if (!camera_internal::IsInDomainOfScalars<kNumParams>(params, point, &IsInDomain)) return false;
    T xd, yd;
    camera_internal::DistortRadTan(params + 4, point[0] / point[2], point[1] / point[2], &xd, &yd);
    pixel[0] = params[0] * xd + params[2];
    pixel[1] = params[1] * yd + params[3];
    return true;
  }

  template <typename T>
  static bool Unproject(const T* params, const T* pixel, T* bearing) {
    double params_scalar[kNumParams];
    for (int i = 0; i < kNumParams; ++i) params_scalar[i] = ScalarPart(params[i]);
    const T xd = (pixel[0] - params[2]) / params[0];
    const T yd = (pixel[1] - params[3]) / params[1];
    double x0, y0;
    if (!Undistort(params_scalar, ScalarPart(xd), ScalarPart(yd), &x0, &y0)) return false;
    T x, y;
    camera_internal::RefineUndistortion(params + 4, xd, yd, x0, y0, &x, &y);
    camera_internal::NormalizeInto(x, y, T(1.0), bearing);
    return true;
  }
};

// ---------------------------------------------------------------------------
// Kannala-Brandt / equidistant fisheye (cv::fisheye, Kannala & Brandt 2006).
// params: fx fy cx cy k1 k2 k3 k4.
//   r = sqrt(X^2 + Y^2),  theta = atan2(r, Z)  (angle from the optical axis),
//   theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8),
//   u = fx theta_d X / r + cx,  v = fy theta_d Y / r + cy
// (on the axis, r -> 0, theta_d / r -> 1 / Z).
// Domain: P != 0 and theta < MaxTheta = min(pi, first positive root of
// d theta_d / d theta); theta may exceed 90 degrees (unlike cv::fisheye,
// which uses atan(r / Z) and folds points behind the camera forward).
// Unproject: safeguarded Newton for theta_d(theta) = |(x, y)| on [0, MaxTheta).
struct KannalaBrandtModel {
  static constexpr CameraModelId kId = CameraModelId::kKannalaBrandt;
  static constexpr std::string_view kName = "kannala_brandt";
  static constexpr int kNumParams = 8;

  // Pixels per radian at the principal point, mean of the two axes.
  static double MeanFocalLength(const double* p) { return 0.5 * (p[0] + p[1]); }
  static std::string_view ParamsError(const double* params);
  static bool IsInDomain(const double* params, const double* point);
  static bool ProjectWithJacobian(const double* params, const double* point, double* pixel, double* jacobian);
  // Supremum of the valid theta (radians), in (0, pi].
  static double MaxTheta(const double* params);
  // theta with theta_d(theta) = theta_d, inside [0, MaxTheta).
  static bool SolveTheta(const double* params, double theta_d, double* theta);
  // d theta_d / d theta.
  static double DistortThetaDerivative(const double* params, double theta);

  template <typename T>
  static T DistortTheta(const T* params, const T& theta) {
    const T t2 = theta * theta;
    return theta * (T(1.0) + t2 * (params[4] + t2 * (params[5] + t2 * (params[6] + t2 * params[7]))));
  }

  // r below 1e-8 Z: theta_d / r = 1/Z up to a relative O(r^2 / Z^2) = 1e-16.
  static bool NearAxis(double r2, double z) { return z > 0.0 && r2 < 1e-16 * z * z; }

  template <typename T>
  static bool Project(const T* params, const T* point, T* pixel) {
    using std::atan2;
    using std::sqrt;
    if (!camera_internal::IsInDomainOfScalars<kNumParams>(params, point, &IsInDomain)) return false;
    const T r2 = point[0] * point[0] + point[1] * point[1];
    T scale;  // theta_d / r
    if (NearAxis(ScalarPart(r2), ScalarPart(point[2]))) {
      scale = T(1.0) / point[2];
    } else {
      const T r = sqrt(r2);
      scale = DistortTheta(params, atan2(r, point[2])) / r;
    }
    pixel[0] = params[0] * scale * point[0] + params[2];
    pixel[1] = params[1] * scale * point[1] + params[3];
    return true;
  }

  template <typename T>
  static bool Unproject(const T* params, const T* pixel, T* bearing) {
    using std::cos;
    using std::sin;
    using std::sqrt;
    double params_scalar[kNumParams];
    for (int i = 0; i < kNumParams; ++i) params_scalar[i] = ScalarPart(params[i]);
    const T mx = (pixel[0] - params[2]) / params[0];
    const T my = (pixel[1] - params[3]) / params[1];
    const double rd0 = std::hypot(ScalarPart(mx), ScalarPart(my));
    double theta0;
    if (!SolveTheta(params_scalar, rd0, &theta0)) return false;
    if (rd0 < 1e-8) {
      // theta = rd (1 + O(rd^2)): the bearing is (mx, my, 1) normalised.
      camera_internal::NormalizeInto(mx, my, T(1.0), bearing);
      return true;
    }
    const T rd = sqrt(mx * mx + my * my);
    const T theta =
        T(theta0) - (DistortTheta(params, T(theta0)) - rd) / T(DistortThetaDerivative(params_scalar, theta0));
    const T sin_over_rd = sin(theta) / rd;
    bearing[0] = sin_over_rd * mx;
    bearing[1] = sin_over_rd * my;
    bearing[2] = cos(theta);
    return true;
  }
};

// ---------------------------------------------------------------------------
// MEI unified omnidirectional model (Mei & Rives 2007; cv::omnidir with skew
// 0; KITTI-360 image_02/03.yaml). params: xi k1 k2 p1 p2 gamma1 gamma2 u0 v0.
//   rho = |P|,  (x, y) = (X, Y) / (Z + xi rho),
//   (xd, yd) = distort(x, y) with {k1, k2, p1, p2, k3 = 0},
//   u = gamma1 xd + u0,  v = gamma2 yd + v0.
// Domain: P != 0 and Z > -w rho with w = xi for xi <= 1 (the denominator stays
// positive) and w = 1/xi for xi > 1 (where d|(x, y)|/d theta = 0: the
// projection folds back beyond it), so the field of view exceeds 180 degrees
// for xi > 0; and x^2 + y^2 below the first positive root of
// 1 + 3 k1 s + 5 k2 s^2 (monotonic distortion).
// Unproject: Newton undistortion, then the closed-form lift to the sphere,
//   P = (f x, f y, f - xi),  f = (xi + sqrt(1 + (1 - xi^2) m^2)) / (1 + m^2),
//   m^2 = x^2 + y^2.
struct MeiModel {
  static constexpr CameraModelId kId = CameraModelId::kMei;
  static constexpr std::string_view kName = "mei";
  static constexpr int kNumParams = 9;

  // Pixels per radian at the principal point, mean of the two axes.
  static double MeanFocalLength(const double* p) { return 0.5 * (p[5] + p[6]) / (1.0 + p[0]); }
  static std::string_view ParamsError(const double* params);
  static bool IsInDomain(const double* params, const double* point);
  static bool ProjectWithJacobian(const double* params, const double* point, double* pixel, double* jacobian);
  // Normalised distorted (xd, yd) -> undistorted (x, y), inside the domain.
  static bool Undistort(const double* params, double xd, double yd, double* x, double* y);

  template <typename T>
  static bool Project(const T* params, const T* point, T* pixel) {
    using std::sqrt;
    if (!camera_internal::IsInDomainOfScalars<kNumParams>(params, point, &IsInDomain)) return false;
    const T rho = sqrt(point[0] * point[0] + point[1] * point[1] + point[2] * point[2]);
    const T denominator = point[2] + params[0] * rho;
    const T k[5] = {params[1], params[2], params[3], params[4], T(0.0)};
    T xd, yd;
    camera_internal::DistortRadTan(k, point[0] / denominator, point[1] / denominator, &xd, &yd);
    pixel[0] = params[5] * xd + params[7];
    pixel[1] = params[6] * yd + params[8];
    return true;
  }

  template <typename T>
  static bool Unproject(const T* params, const T* pixel, T* bearing) {
    using std::sqrt;
    double params_scalar[kNumParams];
    for (int i = 0; i < kNumParams; ++i) params_scalar[i] = ScalarPart(params[i]);
    const T xd = (pixel[0] - params[7]) / params[5];
    const T yd = (pixel[1] - params[8]) / params[6];
    double x0, y0;
    if (!Undistort(params_scalar, ScalarPart(xd), ScalarPart(yd), &x0, &y0)) return false;
    const T k[5] = {params[1], params[2], params[3], params[4], T(0.0)};
    T x, y;
    camera_internal::RefineUndistortion(k, xd, yd, x0, y0, &x, &y);
    const T& xi = params[0];
    const T m2 = x * x + y * y;
    const T discriminant = T(1.0) + (T(1.0) - xi * xi) * m2;
    if (!(ScalarPart(discriminant) > 0.0)) return false;
    const T f = (xi + sqrt(discriminant)) / (T(1.0) + m2);
    const T point[3] = {f * x, f * y, f - xi};
    if (!camera_internal::IsInDomainOfScalars<kNumParams>(params, point, &IsInDomain)) return false;
    camera_internal::NormalizeInto(point[0], point[1], point[2], bearing);
    return true;
  }
};

// ---------------------------------------------------------------------------
// Double sphere (Usenko, Demmel, Cremers, 3DV 2018). params: fx fy cx cy xi
// alpha. Paper eqs. (40)-(50):
//   d1 = |P|,  d2 = |(X, Y, xi d1 + Z)|,
//   u = fx X / (alpha d2 + (1 - alpha)(xi d1 + Z)) + cx  (v likewise).
// Domain (eq. 43): Z > -w2 d1,
//   w1 = alpha / (1 - alpha) if alpha <= 0.5 else (1 - alpha) / alpha,
//   w2 = (w1 + xi) / sqrt(2 w1 xi + xi^2 + 1).
// Unproject (eqs. 46-50), closed form; for alpha > 0.5 only pixels with
// r^2 = mx^2 + my^2 < 1 / (2 alpha - 1).
struct DoubleSphereModel {
  static constexpr CameraModelId kId = CameraModelId::kDoubleSphere;
  static constexpr std::string_view kName = "double_sphere";
  static constexpr int kNumParams = 6;

  // Pixels per radian at the principal point, mean of the two axes.
  static double MeanFocalLength(const double* p) { return 0.5 * (p[0] + p[1]) / (1.0 + p[4]); }
  static std::string_view ParamsError(const double* params);
  static bool IsInDomain(const double* params, const double* point);
  static bool ProjectWithJacobian(const double* params, const double* point, double* pixel, double* jacobian);

  template <typename T>
  static bool Project(const T* params, const T* point, T* pixel) {
    using std::sqrt;
    if (!camera_internal::IsInDomainOfScalars<kNumParams>(params, point, &IsInDomain)) return false;
    const T& xi = params[4];
    const T& alpha = params[5];
    const T xy2 = point[0] * point[0] + point[1] * point[1];
    const T d1 = sqrt(xy2 + point[2] * point[2]);
    const T k = xi * d1 + point[2];
    const T d2 = sqrt(xy2 + k * k);
    const T denominator = alpha * d2 + (T(1.0) - alpha) * k;
    pixel[0] = params[0] * point[0] / denominator + params[2];
    pixel[1] = params[1] * point[1] / denominator + params[3];
    return true;
  }

  template <typename T>
  static bool Unproject(const T* params, const T* pixel, T* bearing) {
    using std::sqrt;
    const T& xi = params[4];
    const T& alpha = params[5];
    const T mx = (pixel[0] - params[2]) / params[0];
    const T my = (pixel[1] - params[3]) / params[1];
    const T r2 = mx * mx + my * my;
    const T radicand = T(1.0) - (T(2.0) * alpha - T(1.0)) * r2;
    if (!(ScalarPart(radicand) > 0.0)) return false;  // alpha > 0.5 and r^2 >= 1 / (2 alpha - 1)
    const T mz = (T(1.0) - alpha * alpha * r2) / (alpha * sqrt(radicand) + T(1.0) - alpha);
    const T discriminant = mz * mz + (T(1.0) - xi * xi) * r2;
    if (!(ScalarPart(discriminant) > 0.0)) return false;
    const T f = (mz * xi + sqrt(discriminant)) / (mz * mz + r2);
    const T point[3] = {f * mx, f * my, f * mz - xi};
    if (!camera_internal::IsInDomainOfScalars<kNumParams>(params, point, &IsInDomain)) return false;
    camera_internal::NormalizeInto(point[0], point[1], point[2], bearing);
    return true;
  }
};

// ---------------------------------------------------------------------------
// Calls f(Model{}) with the model type of `id` and returns its result; f must
// return the same type for every model. Example:
//   int n = VisitCameraModel(id, [](auto model) { return decltype(model)::kNumParams; });
template <typename Func>
decltype(auto) VisitCameraModel(CameraModelId id, Func&& f) {
  switch (id) {
    case CameraModelId::kPinhole:
      return f(PinholeModel{});
    case CameraModelId::kRadTan:
      return f(RadTanModel{});
    case CameraModelId::kKannalaBrandt:
      return f(KannalaBrandtModel{});
    case CameraModelId::kMei:
      return f(MeiModel{});
    case CameraModelId::kDoubleSphere:
      return f(DoubleSphereModel{});
  }
  internal::CheckFailed(__FILE__, __LINE__, "VisitCameraModel",
                        StrCat("bad model id ", static_cast<int>(id)));
}

// All model ids, in enum order (for tests and tables).
inline constexpr CameraModelId kAllCameraModels[] = {CameraModelId::kPinhole, CameraModelId::kRadTan,
                                                     CameraModelId::kKannalaBrandt, CameraModelId::kMei,
                                                     CameraModelId::kDoubleSphere};

}  // namespace mcvo
