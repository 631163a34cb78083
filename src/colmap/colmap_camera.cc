// COLMAP camera models: projection as COLMAP computes it, and the mapping of
// the rig's cameras onto them (exact, fitted, or an undistorted pinhole).
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <string>
#include <vector>

#include <ceres/ceres.h>
#include <opencv2/imgcodecs.hpp>

#include "colmap_internal.h"
#include "mcvo/camera/models.h"
#include "mcvo/colmap/colmap_model.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
constexpr double kDegToRad = M_PI / 180.0;

// COLMAP's OPENCV_FISHEYE (colmap/sensor/models.h, OpenCVFisheyeCameraModel):
// (u, v) = (X, Y) / Z, theta = atan(r), theta_d = theta (1 + k1 theta^2 +
// k2 theta^4 + k3 theta^6 + k4 theta^8), (x, y) = (u, v) theta_d / r
// (identity for r <= DBL_EPSILON), pixel = (fx x + cx, fy y + cy). `params`
// is fx fy cx cy k1..k4 and may be Jets (u, v are data). Same as the
// kannala_brandt model for Z > 0.
template <typename T>
void FisheyeProject(const T* params, double u, double v, T* pixel) {
  const double radius = std::sqrt(u * u + v * v);
  T x = T(u);
  T y = T(v);
  if (radius > DBL_EPSILON) {
    const double theta = std::atan(radius);
    const double t2 = theta * theta;
    const double t4 = t2 * t2;
    const double t6 = t4 * t2;
    const double t8 = t4 * t4;
    const T theta_d = theta * (T(1.0) + params[4] * t2 + params[5] * t4 + params[6] * t6 + params[7] * t8);
    x = T(u) * theta_d / radius;
    y = T(v) * theta_d / radius;
  }
  pixel[0] = params[0] * x + params[2];
  pixel[1] = params[1] * y + params[3];
}

// Brown-Conrady as COLMAP writes it for OPENCV (k3..k6 = 0) and FULL_OPENCV
// (rational radial term): returns the distorted normalised coordinates.
Eigen::Vector2d OpenCvDistort(const double* k, bool full, double u, double v) {
  const double k1 = k[0], k2 = k[1], p1 = k[2], p2 = k[3];
  const double u2 = u * u, uv = u * v, v2 = v * v;
  const double r2 = u2 + v2, r4 = r2 * r2, r6 = r4 * r2;
  double radial;
  if (full) {
    radial = (1.0 + k1 * r2 + k2 * r4 + k[4] * r6) / (1.0 + k[5] * r2 + k[6] * r4 + k[7] * r6);
  } else {
    radial = 1.0 + k1 * r2 + k2 * r4;
  }
  return {u * radial + 2.0 * p1 * uv + p2 * (r2 + 2.0 * u2),
          v * radial + 2.0 * p2 * uv + p1 * (r2 + 2.0 * v2)};
}

// Residual of the OPENCV_FISHEYE fit at one sample: the fitted model's pixel
// of the sample's bearing minus the camera's pixel of it.
struct FisheyeFitResidual {
  double u, v;  // bearing / z
  double pixel_x, pixel_y;

  template <typename T>
  bool operator()(const T* params, T* residual) const {
    T pixel[2];
    FisheyeProject(params, u, v, pixel);
    residual[0] = pixel[0] - T(pixel_x);
    residual[1] = pixel[1] - T(pixel_y);
    return true;
  }
};

struct FitSample {
  Eigen::Vector3d bearing;
  Eigen::Vector2d pixel;  // OpenCV convention
};

bool MaskAllows(const cv::Mat& mask, const Eigen::Vector2d& pixel) {
  if (mask.empty()) return true;
  const int x = static_cast<int>(std::lround(pixel.x()));
  const int y = static_cast<int>(std::lround(pixel.y()));
  if (x < 0 || y < 0 || x >= mask.cols || y >= mask.rows) return false;
  return mask.at<uint8_t>(y, x) != 0;
}

// Pixels per radian at the principal point, per axis, and the principal
// point, of a MEI or double-sphere camera: the fit's starting point.
void InitialFisheyeParams(const Camera& camera, double* params) {
  const std::vector<double>& p = camera.params;
  if (camera.model == CameraModelId::kMei) {
    params[0] = p[5] / (1.0 + p[0]);
    params[1] = p[6] / (1.0 + p[0]);
    params[2] = p[7];
    params[3] = p[8];
  } else {  // double sphere
    params[0] = p[0] / (1.0 + p[4]);
    params[1] = p[1] / (1.0 + p[4]);
    params[2] = p[2];
    params[3] = p[3];
  }
  for (int i = 4; i < 8; ++i) params[i] = 0.0;
}

void FitFisheye(const Camera& camera, const ColmapExportOptions& options, ColmapCameraExport* out) {
  const cv::Mat mask = colmap_internal::ReadCameraMask(camera);
  const int n = options.fit_grid;
  std::vector<FitSample> samples;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d pixel((i + 0.5) * camera.width / n - 0.5, (j + 0.5) * camera.height / n - 0.5);
      if (!MaskAllows(mask, pixel)) continue;
      const std::optional<Eigen::Vector3d> bearing = camera.Unproject(pixel);
      if (!bearing || colmap_internal::AngleFromAxisDeg(*bearing) > options.fisheye_max_angle_deg) continue;
      samples.push_back({*bearing, pixel});
    }
  }
  constexpr int kMinSamples = 20;
  if (static_cast<int>(samples.size()) < kMinSamples) {
    MCVO_THROW_INPUT("camera '", camera.name, "': only ", samples.size(),
                     " valid pixels within /colmap/fisheye_max_angle_deg = ", options.fisheye_max_angle_deg,
                     " on a ", n, "x", n, " grid, too few to fit OPENCV_FISHEYE");
  }

  double params[8];
  InitialFisheyeParams(camera, params);
  ceres::Problem problem;
  for (const FitSample& sample : samples) {
    auto* cost = new ceres::AutoDiffCostFunction<FisheyeFitResidual, 2, 8>(
        new FisheyeFitResidual{sample.bearing.x() / sample.bearing.z(),
                               sample.bearing.y() / sample.bearing.z(), sample.pixel.x(), sample.pixel.y()});
    problem.AddResidualBlock(cost, nullptr, params);
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = 200;
  solver_options.function_tolerance = 1e-15;
  solver_options.gradient_tolerance = 1e-15;
  solver_options.parameter_tolerance = 1e-15;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    MCVO_THROW_INPUT("camera '", camera.name, "': the OPENCV_FISHEYE fit failed: ", summary.message);
  }

  double sum_sq = 0.0;
  double max_error = 0.0;
  for (const FitSample& sample : samples) {
    double pixel[2];
    FisheyeProject(params, sample.bearing.x() / sample.bearing.z(), sample.bearing.y() / sample.bearing.z(),
                   pixel);
    const double error = std::hypot(pixel[0] - sample.pixel.x(), pixel[1] - sample.pixel.y());
    sum_sq += error * error;
    max_error = std::max(max_error, error);
  }
  out->camera.model = ColmapCameraModel::kOpenCvFisheye;
  out->camera.params = {params[0], params[1], params[2] + 0.5, params[3] + 0.5,
                        params[4], params[5], params[6],       params[7]};
  out->fitted = true;
  out->max_angle_deg = options.fisheye_max_angle_deg;
  out->fit_samples = static_cast<int>(samples.size());
  out->fit_rms_px = std::sqrt(sum_sq / static_cast<double>(samples.size()));
  out->fit_max_px = max_error;
}

// Where the camera sees the bearing of the pinhole pixel (x, y) (OpenCV
// convention of both), if inside its image with a one-pixel margin for
// bilinear interpolation and valid in its mask.
bool PinholePixelInside(const Camera& camera, const cv::Mat& mask, double f, double cx, double cy, double x,
                        double y) {
  const std::optional<Eigen::Vector2d> pixel =
      camera.Project(Eigen::Vector3d((x - cx) / f, (y - cy) / f, 1.0));
  if (!pixel) return false;
  if (pixel->x() < 0.0 || pixel->y() < 0.0 || pixel->x() > camera.width - 1.0 ||
      pixel->y() > camera.height - 1.0)
    return false;
  return MaskAllows(mask, *pixel);
}

void DesignUndistortedPinhole(const Camera& camera, const ColmapExportOptions& options,
                              ColmapCameraExport* out) {
  const cv::Mat mask = colmap_internal::ReadCameraMask(camera);
  // Keep the camera's angular resolution at the principal point.
  const double f = camera.MeanFocalLength();
  double half_x = 0.5 * options.undistort_fov_deg * kDegToRad;
  double half_y = half_x;
  constexpr double kStep = 0.5 * kDegToRad;
  constexpr double kMinHalf = 5.0 * kDegToRad;
  while (true) {
    if (half_x < kMinHalf || half_y < kMinHalf) {
      MCVO_THROW_INPUT("camera '", camera.name,
                       "': no undistorted pinhole view of at least 10 degrees fits in its valid image area");
    }
    const int width = 2 * static_cast<int>(std::ceil(f * std::tan(half_x)));
    const int height = 2 * static_cast<int>(std::ceil(f * std::tan(half_y)));
    const double cx = 0.5 * width - 0.5;
    const double cy = 0.5 * height - 0.5;
    // The valid area of the fisheye is star-shaped around its axis: when the
    // border of the pinhole image maps inside it, so does the interior.
    bool left_right_ok = true;
    bool top_bottom_ok = true;
    for (int y = 0; y < height && left_right_ok; ++y) {
      left_right_ok = PinholePixelInside(camera, mask, f, cx, cy, 0.0, y) &&
                      PinholePixelInside(camera, mask, f, cx, cy, width - 1.0, y);
    }
    for (int x = 0; x < width && top_bottom_ok; ++x) {
      top_bottom_ok = PinholePixelInside(camera, mask, f, cx, cy, x, 0.0) &&
                      PinholePixelInside(camera, mask, f, cx, cy, x, height - 1.0);
    }
    if (left_right_ok && top_bottom_ok) {
      out->camera.model = ColmapCameraModel::kPinhole;
      out->camera.width = static_cast<uint64_t>(width);
      out->camera.height = static_cast<uint64_t>(height);
      out->camera.params = {f, f, cx + 0.5, cy + 0.5};
      out->undistorted = true;
      out->fov_x_deg = 2.0 * std::atan(0.5 * width / f) * kRadToDeg;
      out->fov_y_deg = 2.0 * std::atan(0.5 * height / f) * kRadToDeg;
      out->max_angle_deg = 90.0;
      return;
    }
    if (!left_right_ok) half_x -= kStep;
    if (!top_bottom_ok) half_y -= kStep;
  }
}

}  // namespace

std::optional<Eigen::Vector2d> ColmapProject(const ColmapCamera& camera,
                                             const Eigen::Vector3d& point_in_cam) {
  if (point_in_cam.z() < DBL_EPSILON) return std::nullopt;
  if (static_cast<int>(camera.params.size()) != ColmapCameraModelNumParams(camera.model)) return std::nullopt;
  const double u = point_in_cam.x() / point_in_cam.z();
  const double v = point_in_cam.y() / point_in_cam.z();
  const std::vector<double>& p = camera.params;
  switch (camera.model) {
    case ColmapCameraModel::kSimplePinhole:
      return Eigen::Vector2d(p[0] * u + p[1], p[0] * v + p[2]);
    case ColmapCameraModel::kPinhole:
      return Eigen::Vector2d(p[0] * u + p[2], p[1] * v + p[3]);
    case ColmapCameraModel::kSimpleRadial:
    case ColmapCameraModel::kRadial: {
      const double r2 = u * u + v * v;
      const double k2 = camera.model == ColmapCameraModel::kRadial ? p[4] : 0.0;
      const double radial = 1.0 + p[3] * r2 + k2 * r2 * r2;
      return Eigen::Vector2d(p[0] * u * radial + p[1], p[0] * v * radial + p[2]);
    }
    case ColmapCameraModel::kOpenCv:
    case ColmapCameraModel::kFullOpenCv: {
      const bool full = camera.model == ColmapCameraModel::kFullOpenCv;
      const double k[8] = {p[4],
                           p[5],
                           p[6],
                           p[7],
                           full ? p[8] : 0.0,
                           full ? p[9] : 0.0,
                           full ? p[10] : 0.0,
                           full ? p[11] : 0.0};
      const Eigen::Vector2d d = OpenCvDistort(k, full, u, v);
      return Eigen::Vector2d(p[0] * d.x() + p[2], p[1] * d.y() + p[3]);
    }
    case ColmapCameraModel::kOpenCvFisheye: {
      Eigen::Vector2d pixel;
      FisheyeProject(p.data(), u, v, pixel.data());
      return pixel;
    }
    default:
      return std::nullopt;
  }
}

ColmapCameraExport ConvertCameraToColmap(const Camera& camera, uint32_t camera_id,
                                         const ColmapExportOptions& options) {
  if (const std::string error = CameraParamsError(camera.model, camera.params); !error.empty())
    MCVO_THROW_INPUT("camera '", camera.name, "': ", error);
  if (camera.width <= 0 || camera.height <= 0)
    MCVO_THROW_INPUT("camera '", camera.name, "': image size ", camera.width, "x", camera.height,
                     " is empty");
  ColmapCameraExport out;
  out.name = camera.name;
  out.source_model = camera.model;
  out.camera.id = camera_id;
  out.camera.width = static_cast<uint64_t>(camera.width);
  out.camera.height = static_cast<uint64_t>(camera.height);
  const std::vector<double>& p = camera.params;
  switch (camera.model) {
    case CameraModelId::kPinhole:
      out.camera.model = ColmapCameraModel::kPinhole;
      out.camera.params = {p[0], p[1], p[2] + 0.5, p[3] + 0.5};
      break;
    case CameraModelId::kRadTan:
      if (p[8] == 0.0) {
        out.camera.model = ColmapCameraModel::kOpenCv;
        out.camera.params = {p[0], p[1], p[2] + 0.5, p[3] + 0.5, p[4], p[5], p[6], p[7]};
      } else {
        out.camera.model = ColmapCameraModel::kFullOpenCv;
        out.camera.params = {p[0], p[1], p[2] + 0.5, p[3] + 0.5, p[4], p[5], p[6], p[7], p[8], 0.0, 0.0, 0.0};
      }
      break;
    case CameraModelId::kKannalaBrandt:
      out.camera.model = ColmapCameraModel::kOpenCvFisheye;
      out.camera.params = {p[0], p[1], p[2] + 0.5, p[3] + 0.5, p[4], p[5], p[6], p[7]};
      break;
    case CameraModelId::kMei:
    case CameraModelId::kDoubleSphere:
      if (options.fisheye_policy == ColmapFisheyePolicy::kFit) {
        FitFisheye(camera, options, &out);
      } else {
        DesignUndistortedPinhole(camera, options, &out);
      }
      break;
  }
  return out;
}

namespace colmap_internal {

double AngleFromAxisDeg(const Eigen::Vector3d& bearing) {
  return std::atan2(bearing.head<2>().norm(), bearing.z()) * kRadToDeg;
}

cv::Mat ReadCameraMask(const Camera& camera) {
  if (camera.mask_path.empty()) return cv::Mat();
  cv::Mat mask;
  try {
    mask = cv::imread(camera.mask_path, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    MCVO_THROW_INPUT(camera.mask_path, ": cannot read the mask of camera '", camera.name, "': ", e.what());
  }
  if (mask.empty())
    MCVO_THROW_INPUT(camera.mask_path, ": cannot read the mask of camera '", camera.name, "'");
  if (mask.cols != camera.width || mask.rows != camera.height) {
    MCVO_THROW_INPUT(camera.mask_path, ": mask is ", mask.cols, "x", mask.rows, ", camera '", camera.name,
                     "' is ", camera.width, "x", camera.height);
  }
  return mask;
}

std::optional<Eigen::Vector2d> UndistortPixel(const Camera& camera, const ColmapCamera& pinhole,
                                              const Eigen::Vector2d& pixel) {
  const std::optional<Eigen::Vector3d> bearing = camera.Unproject(pixel);
  if (!bearing) return std::nullopt;
  std::optional<Eigen::Vector2d> out = ColmapProject(pinhole, *bearing);
  if (!out) return std::nullopt;
  // Inside the pinhole image [0, w) x [0, h) in COLMAP's convention.
  if (!(out->x() >= 0.0 && out->y() >= 0.0 && out->x() < static_cast<double>(pinhole.width) &&
        out->y() < static_cast<double>(pinhole.height)))
    return std::nullopt;
  return out;
}

void MakeUndistortMaps(const Camera& camera, const ColmapCamera& pinhole, cv::Mat* map_x, cv::Mat* map_y) {
  MCVO_CHECK(pinhole.model == ColmapCameraModel::kPinhole);
  const int width = static_cast<int>(pinhole.width);
  const int height = static_cast<int>(pinhole.height);
  const double fx = pinhole.params[0], fy = pinhole.params[1];
  // Principal point back in OpenCV's convention.
  const double cx = pinhole.params[2] - 0.5, cy = pinhole.params[3] - 0.5;
  map_x->create(height, width, CV_32FC1);
  map_y->create(height, width, CV_32FC1);
  for (int y = 0; y < height; ++y) {
    float* row_x = map_x->ptr<float>(y);
    float* row_y = map_y->ptr<float>(y);
    for (int x = 0; x < width; ++x) {
      const std::optional<Eigen::Vector2d> pixel =
          camera.Project(Eigen::Vector3d((x - cx) / fx, (y - cy) / fy, 1.0));
      row_x[x] = pixel ? static_cast<float>(pixel->x()) : -1.0f;
      row_y[x] = pixel ? static_cast<float>(pixel->y()) : -1.0f;
    }
  }
}

}  // namespace colmap_internal
}  // namespace mcvo
