// Run-time dispatch from Camera (a model id and a parameter vector) to the
// templated models of camera/models.h, through VisitCameraModel.
#include "mcvo/camera/camera.h"

#include <array>
#include <cmath>
#include <utility>

#include "mcvo/camera/models.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

// Names and aliases, canonical name first per model.
constexpr std::array<std::pair<std::string_view, CameraModelId>, 10> kModelNames = {{
    {"pinhole", CameraModelId::kPinhole},
    {"radtan", CameraModelId::kRadTan},
    {"kannala_brandt", CameraModelId::kKannalaBrandt},
    {"mei", CameraModelId::kMei},
    {"double_sphere", CameraModelId::kDoubleSphere},
    {"opencv", CameraModelId::kRadTan},
    {"equidistant", CameraModelId::kKannalaBrandt},
    {"fisheye", CameraModelId::kKannalaBrandt},
    {"omni", CameraModelId::kMei},
    {"unified", CameraModelId::kMei},
}};

void CheckNumParams(const Camera& camera) {
  MCVO_CHECK_MSG(static_cast<int>(camera.params.size()) == CameraModelNumParams(camera.model), "camera '",
                 camera.name, "' (", CameraModelName(camera.model), ") has ", camera.params.size(),
                 " parameters, expected ", CameraModelNumParams(camera.model));
}

}  // namespace

std::string_view CameraModelName(CameraModelId id) {
  return VisitCameraModel(id, [](auto model) { return decltype(model)::kName; });
}

std::optional<CameraModelId> CameraModelFromName(std::string_view name) {
  for (const auto& [model_name, id] : kModelNames) {
    if (model_name == name) return id;
  }
  return std::nullopt;
}

int CameraModelNumParams(CameraModelId id) {
  return VisitCameraModel(id, [](auto model) { return decltype(model)::kNumParams; });
}

bool IsFisheyeModel(CameraModelId id) {
  return id == CameraModelId::kKannalaBrandt || id == CameraModelId::kMei || id == CameraModelId::kDoubleSphere;
}

std::string CameraParamsError(CameraModelId id, const std::vector<double>& params) {
  const int expected = CameraModelNumParams(id);
  if (static_cast<int>(params.size()) != expected) {
    return StrCat("model ", CameraModelName(id), " expects ", expected, " parameters, got ", params.size());
  }
  return std::string(
      VisitCameraModel(id, [&](auto model) { return decltype(model)::ParamsError(params.data()); }));
}

std::optional<Eigen::Vector2d> Camera::Project(const Eigen::Vector3d& point_in_cam) const {
  CheckNumParams(*this);
  return VisitCameraModel(model, [&](auto m) -> std::optional<Eigen::Vector2d> {
    Eigen::Vector2d pixel;
    if (!decltype(m)::Project(params.data(), point_in_cam.data(), pixel.data())) return std::nullopt;
    return pixel;
  });
}

std::optional<Eigen::Vector2d> Camera::Project(const Eigen::Vector3d& point_in_cam,
                                               Eigen::Matrix<double, 2, 3>* jacobian) const {
  CheckNumParams(*this);
  return VisitCameraModel(model, [&](auto m) -> std::optional<Eigen::Vector2d> {
    Eigen::Vector2d pixel;
    Eigen::Matrix<double, 2, 3, Eigen::RowMajor> jacobian_row_major;
    if (!decltype(m)::ProjectWithJacobian(params.data(), point_in_cam.data(), pixel.data(),
                                          jacobian != nullptr ? jacobian_row_major.data() : nullptr)) {
      return std::nullopt;
    }
    if (jacobian != nullptr) *jacobian = jacobian_row_major;
    return pixel;
  });
}

std::optional<Eigen::Vector3d> Camera::Unproject(const Eigen::Vector2d& pixel) const {
  CheckNumParams(*this);
  return VisitCameraModel(model, [&](auto m) -> std::optional<Eigen::Vector3d> {
    Eigen::Vector3d bearing;
    if (!decltype(m)::Unproject(params.data(), pixel.data(), bearing.data())) return std::nullopt;
    return bearing;
  });
}

bool Camera::IsInImage(const Eigen::Vector2d& pixel) const {
  return pixel.x() >= -0.5 && pixel.x() < width - 0.5 && pixel.y() >= -0.5 && pixel.y() < height - 0.5;
}

double Camera::MeanFocalLength() const {
  CheckNumParams(*this);
  return VisitCameraModel(model, [&](auto m) { return decltype(m)::MeanFocalLength(params.data()); });
}

std::vector<Rigid3d> Rig::CamFromRig() const {
  std::vector<Rigid3d> out;
  out.reserve(cameras.size());
  for (const Camera& camera : cameras) out.push_back(camera.cam_from_rig);
  return out;
}

int Rig::FindCamera(std::string_view camera_name) const {
  for (int i = 0; i < NumCameras(); ++i) {
    if (cameras[i].name == camera_name) return i;
  }
  return -1;
}

Camera ScaledCamera(const Camera& camera, double scale) {
  if (!(scale > 0.0 && scale <= 4.0)) {
    MCVO_THROW_INPUT("image scale must be in (0, 4], got ", FormatDouble(scale));
  }
  Camera scaled = camera;
  scaled.width = static_cast<int>(std::lround(camera.width * scale));
  scaled.height = static_cast<int>(std::lround(camera.height * scale));
  if (scaled.width < 1 || scaled.height < 1) {
    MCVO_THROW_INPUT("camera ", camera.name, ": image scale ", FormatDouble(scale), " leaves no pixels (",
                     camera.width, " x ", camera.height, ")");
  }
  const double rx = static_cast<double>(scaled.width) / camera.width;
  const double ry = static_cast<double>(scaled.height) / camera.height;
  // Index of fx (or gamma1); fy, cx, cy (or gamma2, u0, v0) follow it.
  const size_t first = camera.model == CameraModelId::kMei ? 5 : 0;
  MCVO_CHECK(scaled.params.size() >= first + 4);
  scaled.params[first + 0] *= rx;
  scaled.params[first + 1] *= ry;
  scaled.params[first + 2] = rx * (camera.params[first + 2] + 0.5) - 0.5;
  scaled.params[first + 3] = ry * (camera.params[first + 3] + 0.5) - 0.5;
  return scaled;
}

}  // namespace mcvo
