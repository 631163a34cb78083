// The COLMAP model in memory: camera model table, lookups, comparison, and
// the checks shared by the text and binary readers and writers.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "colmap_internal.h"
#include "mcvo/colmap/colmap_model.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

struct ModelInfo {
  ColmapCameraModel model;
  std::string_view name;
  int num_params;
};

constexpr ModelInfo kModels[] = {
    {ColmapCameraModel::kSimplePinhole, "SIMPLE_PINHOLE", 3},
    {ColmapCameraModel::kPinhole, "PINHOLE", 4},
    {ColmapCameraModel::kSimpleRadial, "SIMPLE_RADIAL", 4},
    {ColmapCameraModel::kRadial, "RADIAL", 5},
    {ColmapCameraModel::kOpenCv, "OPENCV", 8},
    {ColmapCameraModel::kOpenCvFisheye, "OPENCV_FISHEYE", 8},
    {ColmapCameraModel::kFullOpenCv, "FULL_OPENCV", 12},
    {ColmapCameraModel::kFov, "FOV", 5},
    {ColmapCameraModel::kSimpleRadialFisheye, "SIMPLE_RADIAL_FISHEYE", 4},
    {ColmapCameraModel::kRadialFisheye, "RADIAL_FISHEYE", 5},
    {ColmapCameraModel::kThinPrismFisheye, "THIN_PRISM_FISHEYE", 12},
};

const ModelInfo& Info(ColmapCameraModel model) {
  for (const ModelInfo& info : kModels) {
    if (info.model == model) return info;
  }
  MCVO_CHECK_MSG(false, "bad COLMAP camera model ", static_cast<int>(model));
  return kModels[0];
}

// Sorts a list by id and rejects duplicate ids.
template <typename T>
void SortById(std::vector<T>* items, const fs::path& file, const char* what) {
  std::stable_sort(items->begin(), items->end(), [](const T& a, const T& b) { return a.id < b.id; });
  for (size_t i = 1; i < items->size(); ++i) {
    if ((*items)[i].id == (*items)[i - 1].id)
      MCVO_THROW_INPUT(file.string(), ": duplicate ", what, " id ", (*items)[i].id);
  }
}

// MCVO_CHECKs that the ids of a list are strictly ascending.
template <typename T>
void CheckSorted(const std::vector<T>& items, const char* what) {
  for (size_t i = 1; i < items.size(); ++i)
    MCVO_CHECK_MSG(items[i - 1].id < items[i].id, what, " ids must be strictly ascending");
}

}  // namespace

// ---------------------------------------------------------------------------

std::string_view ColmapCameraModelName(ColmapCameraModel model) { return Info(model).name; }

std::optional<ColmapCameraModel> ColmapCameraModelFromName(std::string_view name) {
  for (const ModelInfo& info : kModels) {
    if (info.name == name) return info.model;
  }
  return std::nullopt;
}

std::optional<ColmapCameraModel> ColmapCameraModelFromId(int id) {
  for (const ModelInfo& info : kModels) {
    if (static_cast<int>(info.model) == id) return info.model;
  }
  return std::nullopt;
}

int ColmapCameraModelNumParams(ColmapCameraModel model) { return Info(model).num_params; }

namespace {
template <typename T, typename Id>
const T* FindById(const std::vector<T>& items, Id id) {
  const auto it =
      std::lower_bound(items.begin(), items.end(), id, [](const T& item, Id v) { return item.id < v; });
  return it != items.end() && it->id == id ? &*it : nullptr;
}
}  // namespace

const ColmapCamera* ColmapModel::FindCamera(uint32_t id) const { return FindById(cameras, id); }
const ColmapImage* ColmapModel::FindImage(uint32_t id) const { return FindById(images, id); }
const ColmapPoint3D* ColmapModel::FindPoint3D(uint64_t id) const { return FindById(points3d, id); }

int64_t ColmapModel::NumObservations() const {
  int64_t n = 0;
  for (const ColmapImage& image : images) {
    for (uint64_t id : image.point3d_ids) n += id != kColmapNoPoint3D ? 1 : 0;
  }
  return n;
}

namespace colmap_internal {

void FinishReadModel(const fs::path& dir, const std::string& ext, ColmapModel* model) {
  SortById(&model->cameras, dir / ("cameras" + ext), "camera");
  SortById(&model->images, dir / ("images" + ext), "image");
  SortById(&model->points3d, dir / ("points3D" + ext), "point3D");
  SortById(&model->rigs, dir / ("rigs" + ext), "rig");
  SortById(&model->frames, dir / ("frames" + ext), "frame");
  if (model->rigs.empty() != model->frames.empty())
    MCVO_THROW_INPUT(dir.string(), ": rigs", ext, " and frames", ext, " must be present together");
}

void CheckWritableModel(const ColmapModel& model) {
  CheckSorted(model.cameras, "camera");
  CheckSorted(model.images, "image");
  CheckSorted(model.points3d, "point3D");
  CheckSorted(model.rigs, "rig");
  CheckSorted(model.frames, "frame");
  for (const ColmapCamera& camera : model.cameras)
    MCVO_CHECK(static_cast<int>(camera.params.size()) == ColmapCameraModelNumParams(camera.model));
  for (const ColmapImage& image : model.images) {
    MCVO_CHECK(image.points2d.size() == image.point3d_ids.size());
    MCVO_CHECK_MSG(!image.name.empty() && image.name.find_first_of(" \t\r\n") == std::string::npos,
                   "COLMAP image names cannot hold blanks: '", image.name, "'");
  }
}

}  // namespace colmap_internal

ColmapModel ReadColmapModel(const fs::path& dir) {
  std::error_code ec;
  const bool binary = fs::exists(dir / "cameras.bin", ec) && fs::exists(dir / "images.bin", ec) &&
                      fs::exists(dir / "points3D.bin", ec);
  if (binary) return ReadColmapModelBinary(dir);
  if (!fs::exists(dir / "cameras.txt", ec))
    MCVO_THROW_INPUT(dir.string(), ": no COLMAP model (cameras.bin or cameras.txt) in this folder");
  return ReadColmapModelText(dir);
}

// ---------------------------------------------------------------------------

namespace {

bool Near(double a, double b, double tolerance) { return a == b || std::abs(a - b) <= tolerance; }

std::string PoseDiff(const Rigid3d& a, const Rigid3d& b, double tolerance) {
  const Eigen::Quaterniond& qa = a.rotation;
  const Eigen::Quaterniond& qb = b.rotation;
  const double va[7] = {qa.w(),           qa.x(), qa.y(), qa.z(), a.translation.x(), a.translation.y(),
                        a.translation.z()};
  const double vb[7] = {qb.w(),           qb.x(), qb.y(), qb.z(), b.translation.x(), b.translation.y(),
                        b.translation.z()};
  for (int i = 0; i < 7; ++i) {
    if (!Near(va[i], vb[i], tolerance))
      return StrCat("pose value ", i, " (qw qx qy qz tx ty tz): ", FormatDouble(va[i]), " vs ",
                    FormatDouble(vb[i]));
  }
  return "";
}

}  // namespace

std::string DiffColmapModels(const ColmapModel& a, const ColmapModel& b, double tolerance) {
  if (a.cameras.size() != b.cameras.size())
    return StrCat("cameras: ", a.cameras.size(), " vs ", b.cameras.size());
  for (size_t i = 0; i < a.cameras.size(); ++i) {
    const ColmapCamera& x = a.cameras[i];
    const ColmapCamera& y = b.cameras[i];
    const std::string where = StrCat("camera ", x.id, ": ");
    if (x.id != y.id) return StrCat(where, "id vs ", y.id);
    if (x.model != y.model || x.width != y.width || x.height != y.height ||
        x.params.size() != y.params.size())
      return StrCat(where, "model or size differs");
    for (size_t k = 0; k < x.params.size(); ++k) {
      if (!Near(x.params[k], y.params[k], tolerance))
        return StrCat(where, "param ", k, ": ", FormatDouble(x.params[k]), " vs ", FormatDouble(y.params[k]));
    }
  }
  if (a.images.size() != b.images.size()) return StrCat("images: ", a.images.size(), " vs ", b.images.size());
  for (size_t i = 0; i < a.images.size(); ++i) {
    const ColmapImage& x = a.images[i];
    const ColmapImage& y = b.images[i];
    const std::string where = StrCat("image ", x.id, ": ");
    if (x.id != y.id) return StrCat(where, "id vs ", y.id);
    if (x.camera_id != y.camera_id || x.name != y.name)
      return StrCat(where, "camera ", x.camera_id, " '", x.name, "' vs camera ", y.camera_id, " '", y.name,
                    "'");
    if (const std::string d = PoseDiff(x.cam_from_world, y.cam_from_world, tolerance); !d.empty())
      return where + d;
    if (x.points2d.size() != y.points2d.size())
      return StrCat(where, "points2D: ", x.points2d.size(), " vs ", y.points2d.size());
    for (size_t k = 0; k < x.points2d.size(); ++k) {
      if (x.point3d_ids[k] != y.point3d_ids[k]) return StrCat(where, "point2D ", k, ": point3D id differs");
      if (!Near(x.points2d[k].x(), y.points2d[k].x(), tolerance) ||
          !Near(x.points2d[k].y(), y.points2d[k].y(), tolerance))
        return StrCat(where, "point2D ", k, ": position differs");
    }
  }
  if (a.points3d.size() != b.points3d.size())
    return StrCat("points3D: ", a.points3d.size(), " vs ", b.points3d.size());
  for (size_t i = 0; i < a.points3d.size(); ++i) {
    const ColmapPoint3D& x = a.points3d[i];
    const ColmapPoint3D& y = b.points3d[i];
    const std::string where = StrCat("point3D ", x.id, ": ");
    if (x.id != y.id) return StrCat(where, "id vs ", y.id);
    for (int k = 0; k < 3; ++k) {
      if (!Near(x.xyz[k], y.xyz[k], tolerance)) return StrCat(where, "xyz differs");
    }
    if (x.rgb != y.rgb) return StrCat(where, "color differs");
    if (!Near(x.error, y.error, tolerance))
      return StrCat(where, "error ", FormatDouble(x.error), " vs ", FormatDouble(y.error));
    if (x.track.size() != y.track.size()) return StrCat(where, "track length differs");
    for (size_t k = 0; k < x.track.size(); ++k) {
      if (x.track[k].image_id != y.track[k].image_id || x.track[k].point2d_idx != y.track[k].point2d_idx)
        return StrCat(where, "track element ", k, " differs");
    }
  }
  if (a.rigs.size() != b.rigs.size()) return StrCat("rigs: ", a.rigs.size(), " vs ", b.rigs.size());
  for (size_t i = 0; i < a.rigs.size(); ++i) {
    const ColmapRig& x = a.rigs[i];
    const ColmapRig& y = b.rigs[i];
    const std::string where = StrCat("rig ", x.id, ": ");
    if (x.id != y.id || x.ref_camera_id != y.ref_camera_id || x.sensors.size() != y.sensors.size())
      return where + "id, reference or sensors differ";
    for (size_t k = 0; k < x.sensors.size(); ++k) {
      if (x.sensors[k].camera_id != y.sensors[k].camera_id ||
          x.sensors[k].sensor_from_rig.has_value() != y.sensors[k].sensor_from_rig.has_value())
        return StrCat(where, "sensor ", k, " differs");
      if (x.sensors[k].sensor_from_rig) {
        if (const std::string d =
                PoseDiff(*x.sensors[k].sensor_from_rig, *y.sensors[k].sensor_from_rig, tolerance);
            !d.empty())
          return StrCat(where, "sensor ", k, ": ", d);
      }
    }
  }
  if (a.frames.size() != b.frames.size()) return StrCat("frames: ", a.frames.size(), " vs ", b.frames.size());
  for (size_t i = 0; i < a.frames.size(); ++i) {
    const ColmapFrame& x = a.frames[i];
    const ColmapFrame& y = b.frames[i];
    const std::string where = StrCat("frame ", x.id, ": ");
    if (x.id != y.id || x.rig_id != y.rig_id || x.data.size() != y.data.size())
      return where + "id, rig or data differ";
    for (size_t k = 0; k < x.data.size(); ++k) {
      if (x.data[k].camera_id != y.data[k].camera_id || x.data[k].image_id != y.data[k].image_id)
        return StrCat(where, "data ", k, " differs");
    }
    if (const std::string d = PoseDiff(x.rig_from_world, y.rig_from_world, tolerance); !d.empty())
      return where + d;
  }
  return "";
}

}  // namespace mcvo
