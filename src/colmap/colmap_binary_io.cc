// COLMAP's binary model files (cameras, images, points3D; rigs, frames of
// COLMAP 3.12+), following COLMAP's src/colmap/scene/reconstruction_io_binary.cc
// field for field: little endian, whatever the host.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>
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

class BinaryWriter {
 public:
  template <typename T>
  void Put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (!IsLittleEndian()) std::reverse(bytes, bytes + sizeof(T));
    out_.append(reinterpret_cast<const char*>(bytes), sizeof(T));
  }
  void PutPose(const Rigid3d& pose) {
    const Eigen::Quaterniond& q = pose.rotation;
    for (double v : {q.w(), q.x(), q.y(), q.z()}) Put<double>(v);
    for (int i = 0; i < 3; ++i) Put<double>(pose.translation[i]);
  }
  void PutString(const std::string& text) {
    out_ += text;
    out_ += '\0';
  }
  const std::string& data() const { return out_; }

  static bool IsLittleEndian() {
    const uint16_t probe = 1;
    unsigned char first;
    std::memcpy(&first, &probe, 1);
    return first == 1;
  }

 private:
  std::string out_;
};

class BinaryReader {
 public:
  explicit BinaryReader(fs::path path) : path_(std::move(path)), data_(ReadFileToString(path_)) {}

  template <typename T>
  T Get(const char* field) {
    Need(sizeof(T), field);
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, data_.data() + pos_, sizeof(T));
    if (!BinaryWriter::IsLittleEndian()) std::reverse(bytes, bytes + sizeof(T));
    pos_ += sizeof(T);
    T value;
    std::memcpy(&value, bytes, sizeof(T));
    return value;
  }
  double Real(const char* field) {
    const double value = Get<double>(field);
    if (!std::isfinite(value)) Fail(StrCat(field, ": not a finite number"));
    return value;
  }
  Rigid3d Pose(const char* field) {
    Rigid3d pose;
    const double w = Real(field), x = Real(field), y = Real(field), z = Real(field);
    pose.rotation = Eigen::Quaterniond(w, x, y, z);
    for (int i = 0; i < 3; ++i) pose.translation[i] = Real(field);
    return pose;
  }
  std::string String(const char* field) {
    const size_t end = data_.find('\0', pos_);
    if (end == std::string::npos) Fail(StrCat(field, ": missing the terminating NUL"));
    std::string text = data_.substr(pos_, end - pos_);
    pos_ = end + 1;
    return text;
  }
  void Sensor(const char* field) {
    const int type = Get<int32_t>(field);
    if (type != colmap_internal::kSensorCamera)
      Fail(StrCat(field, ": only CAMERA sensors (0) are supported, got ", type));
  }
  // A count of records of at least `min_bytes` each that must fit in the rest of the file.
  uint64_t Count(const char* field, size_t min_bytes) {
    const uint64_t n = Get<uint64_t>(field);
    if (n > (data_.size() - pos_) / std::max<size_t>(min_bytes, 1))
      Fail(StrCat(field, ": file truncated (", n, " records do not fit in it)"));
    return n;
  }
  void End() {
    if (pos_ != data_.size()) Fail(StrCat(data_.size() - pos_, " unexpected bytes at the end"));
  }
  [[noreturn]] void Fail(const std::string& message) const {
    MCVO_THROW_INPUT(path_.string(), ": offset ", pos_, ": ", message);
  }

 private:
  void Need(size_t bytes, const char* field) {
    if (data_.size() - pos_ < bytes) Fail(StrCat(field, ": file truncated"));
  }

  fs::path path_;
  std::string data_;
  size_t pos_ = 0;
};

std::string CamerasBinary(const ColmapModel& model) {
  BinaryWriter out;
  out.Put<uint64_t>(model.cameras.size());
  for (const ColmapCamera& camera : model.cameras) {
    out.Put<uint32_t>(camera.id);
    out.Put<int32_t>(static_cast<int32_t>(camera.model));
    out.Put<uint64_t>(camera.width);
    out.Put<uint64_t>(camera.height);
    for (double p : camera.params) out.Put<double>(p);
  }
  return out.data();
}

std::string ImagesBinary(const ColmapModel& model) {
  BinaryWriter out;
  out.Put<uint64_t>(model.images.size());
  for (const ColmapImage& image : model.images) {
    out.Put<uint32_t>(image.id);
    out.PutPose(image.cam_from_world);
    out.Put<uint32_t>(image.camera_id);
    out.PutString(image.name);
    out.Put<uint64_t>(image.points2d.size());
    for (size_t i = 0; i < image.points2d.size(); ++i) {
      out.Put<double>(image.points2d[i].x());
      out.Put<double>(image.points2d[i].y());
      out.Put<uint64_t>(image.point3d_ids[i]);
    }
  }
  return out.data();
}

std::string Points3DBinary(const ColmapModel& model) {
  BinaryWriter out;
  out.Put<uint64_t>(model.points3d.size());
  for (const ColmapPoint3D& point : model.points3d) {
    out.Put<uint64_t>(point.id);
    for (int i = 0; i < 3; ++i) out.Put<double>(point.xyz[i]);
    for (int i = 0; i < 3; ++i) out.Put<uint8_t>(point.rgb[i]);
    out.Put<double>(point.error);
    out.Put<uint64_t>(point.track.size());
    for (const ColmapTrackElement& element : point.track) {
      out.Put<uint32_t>(element.image_id);
      out.Put<uint32_t>(element.point2d_idx);
    }
  }
  return out.data();
}

std::string RigsBinary(const ColmapModel& model) {
  BinaryWriter out;
  out.Put<uint64_t>(model.rigs.size());
  for (const ColmapRig& rig : model.rigs) {
    out.Put<uint32_t>(rig.id);
    out.Put<uint32_t>(static_cast<uint32_t>(rig.sensors.size() + 1));
    out.Put<int32_t>(colmap_internal::kSensorCamera);
    out.Put<uint32_t>(rig.ref_camera_id);
    for (const ColmapRigSensor& sensor : rig.sensors) {
      out.Put<int32_t>(colmap_internal::kSensorCamera);
      out.Put<uint32_t>(sensor.camera_id);
      out.Put<uint8_t>(sensor.sensor_from_rig ? 1 : 0);
      if (sensor.sensor_from_rig) out.PutPose(*sensor.sensor_from_rig);
    }
  }
  return out.data();
}

std::string FramesBinary(const ColmapModel& model) {
  BinaryWriter out;
  out.Put<uint64_t>(model.frames.size());
  for (const ColmapFrame& frame : model.frames) {
    out.Put<uint32_t>(frame.id);
    out.Put<uint32_t>(frame.rig_id);
    out.PutPose(frame.rig_from_world);
    out.Put<uint32_t>(static_cast<uint32_t>(frame.data.size()));
    for (const ColmapFrameData& data : frame.data) {
      out.Put<int32_t>(colmap_internal::kSensorCamera);
      out.Put<uint32_t>(data.camera_id);
      out.Put<uint64_t>(data.image_id);
    }
  }
  return out.data();
}

void ReadCamerasBinary(const fs::path& path, ColmapModel* model) {
  BinaryReader in(path);
  const uint64_t n = in.Count("number of cameras", 24);
  for (uint64_t i = 0; i < n; ++i) {
    ColmapCamera camera;
    camera.id = in.Get<uint32_t>("camera_id");
    const int32_t model_id = in.Get<int32_t>("model_id");
    const std::optional<ColmapCameraModel> camera_model = ColmapCameraModelFromId(model_id);
    if (!camera_model) in.Fail(StrCat("model_id: unknown COLMAP camera model ", model_id));
    camera.model = *camera_model;
    camera.width = in.Get<uint64_t>("width");
    camera.height = in.Get<uint64_t>("height");
    camera.params.resize(ColmapCameraModelNumParams(camera.model));
    for (double& p : camera.params) p = in.Real("params");
    model->cameras.push_back(std::move(camera));
  }
  in.End();
}

void ReadImagesBinary(const fs::path& path, ColmapModel* model) {
  BinaryReader in(path);
  const uint64_t n = in.Count("number of images", 73);
  for (uint64_t i = 0; i < n; ++i) {
    ColmapImage image;
    image.id = in.Get<uint32_t>("image_id");
    image.cam_from_world = in.Pose("cam_from_world");
    image.camera_id = in.Get<uint32_t>("camera_id");
    image.name = in.String("name");
    const uint64_t num_points = in.Count("number of points2D", 24);
    image.points2d.reserve(num_points);
    image.point3d_ids.reserve(num_points);
    for (uint64_t j = 0; j < num_points; ++j) {
      const double x = in.Real("x");
      const double y = in.Real("y");
      image.points2d.emplace_back(x, y);
      image.point3d_ids.push_back(in.Get<uint64_t>("point3D_id"));
    }
    model->images.push_back(std::move(image));
  }
  in.End();
}

void ReadPoints3DBinary(const fs::path& path, ColmapModel* model) {
  BinaryReader in(path);
  const uint64_t n = in.Count("number of points3D", 51);
  for (uint64_t i = 0; i < n; ++i) {
    ColmapPoint3D point;
    point.id = in.Get<uint64_t>("point3D_id");
    for (int k = 0; k < 3; ++k) point.xyz[k] = in.Real("xyz");
    for (int k = 0; k < 3; ++k) point.rgb[k] = in.Get<uint8_t>("rgb");
    point.error = in.Get<double>("error");
    const uint64_t length = in.Count("track length", 8);
    point.track.reserve(length);
    for (uint64_t j = 0; j < length; ++j) {
      ColmapTrackElement element;
      element.image_id = in.Get<uint32_t>("image_id");
      element.point2d_idx = in.Get<uint32_t>("point2D_idx");
      point.track.push_back(element);
    }
    model->points3d.push_back(std::move(point));
  }
  in.End();
}

void ReadRigsBinary(const fs::path& path, ColmapModel* model) {
  BinaryReader in(path);
  const uint64_t n = in.Count("number of rigs", 16);
  for (uint64_t i = 0; i < n; ++i) {
    ColmapRig rig;
    rig.id = in.Get<uint32_t>("rig_id");
    const uint32_t num_sensors = in.Get<uint32_t>("num_sensors");
    if (num_sensors == 0) in.Fail("num_sensors: a rig without sensors is not supported");
    in.Sensor("ref_sensor_type");
    rig.ref_camera_id = in.Get<uint32_t>("ref_sensor_id");
    for (uint32_t j = 1; j < num_sensors; ++j) {
      ColmapRigSensor sensor;
      in.Sensor("sensor_type");
      sensor.camera_id = in.Get<uint32_t>("sensor_id");
      if (in.Get<uint8_t>("has_pose") != 0) sensor.sensor_from_rig = in.Pose("sensor_from_rig");
      rig.sensors.push_back(sensor);
    }
    model->rigs.push_back(std::move(rig));
  }
  in.End();
}

void ReadFramesBinary(const fs::path& path, ColmapModel* model) {
  BinaryReader in(path);
  const uint64_t n = in.Count("number of frames", 68);
  for (uint64_t i = 0; i < n; ++i) {
    ColmapFrame frame;
    frame.id = in.Get<uint32_t>("frame_id");
    frame.rig_id = in.Get<uint32_t>("rig_id");
    frame.rig_from_world = in.Pose("rig_from_world");
    const uint32_t num_data = in.Get<uint32_t>("num_data_ids");
    for (uint32_t j = 0; j < num_data; ++j) {
      ColmapFrameData data;
      in.Sensor("sensor_type");
      data.camera_id = in.Get<uint32_t>("sensor_id");
      data.image_id = in.Get<uint64_t>("data_id");
      frame.data.push_back(data);
    }
    model->frames.push_back(std::move(frame));
  }
  in.End();
}

}  // namespace

void WriteColmapModelBinary(const ColmapModel& model, const fs::path& dir) {
  colmap_internal::CheckWritableModel(model);
  CreateDirectories(dir);
  WriteFileAtomic(dir / "cameras.bin", CamerasBinary(model));
  WriteFileAtomic(dir / "images.bin", ImagesBinary(model));
  WriteFileAtomic(dir / "points3D.bin", Points3DBinary(model));
  if (!model.rigs.empty()) {
    WriteFileAtomic(dir / "rigs.bin", RigsBinary(model));
    WriteFileAtomic(dir / "frames.bin", FramesBinary(model));
  }
}

ColmapModel ReadColmapModelBinary(const fs::path& dir) {
  ColmapModel model;
  ReadCamerasBinary(dir / "cameras.bin", &model);
  ReadImagesBinary(dir / "images.bin", &model);
  ReadPoints3DBinary(dir / "points3D.bin", &model);
  std::error_code ec;
  if (fs::exists(dir / "rigs.bin", ec)) ReadRigsBinary(dir / "rigs.bin", &model);
  if (fs::exists(dir / "frames.bin", ec)) ReadFramesBinary(dir / "frames.bin", &model);
  colmap_internal::FinishReadModel(dir, ".bin", &model);
  return model;
}

}  // namespace mcvo
