// COLMAP's text model files (cameras, images, points3D; rigs, frames of
// COLMAP 3.12+), following COLMAP's src/colmap/scene/reconstruction_io_text.cc
// field for field. Numbers are written in their shortest round-trip form.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
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

std::string Num(double value) { return FormatDouble(value); }

void AppendPose(const Rigid3d& pose, std::string* line) {
  const Eigen::Quaterniond& q = pose.rotation;
  const Eigen::Vector3d& t = pose.translation;
  for (double v : {q.w(), q.x(), q.y(), q.z(), t.x(), t.y(), t.z()}) *line += " " + Num(v);
}

std::string CamerasText(const ColmapModel& model) {
  std::string out = "# Camera list with one line of data per camera:\n";
  out += "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  out += "# Number of cameras: " + std::to_string(model.cameras.size()) + "\n";
  for (const ColmapCamera& camera : model.cameras) {
    out += std::to_string(camera.id) + " " + std::string(ColmapCameraModelName(camera.model)) + " " +
           std::to_string(camera.width) + " " + std::to_string(camera.height);
    for (double p : camera.params) out += " " + Num(p);
    out += "\n";
  }
  return out;
}

std::string ImagesText(const ColmapModel& model) {
  const double mean_observations = model.images.empty() ? 0.0
                                                        : static_cast<double>(model.NumObservations()) /
                                                              static_cast<double>(model.images.size());
  std::string out = "# Image list with two lines of data per image:\n";
  out += "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n";
  out += "#   POINTS2D[] as (X, Y, POINT3D_ID)\n";
  out += "# Number of images: " + std::to_string(model.images.size()) +
         ", mean observations per image: " + Num(mean_observations) + "\n";
  for (const ColmapImage& image : model.images) {
    std::string line = std::to_string(image.id);
    AppendPose(image.cam_from_world, &line);
    line += " " + std::to_string(image.camera_id) + " " + image.name + "\n";
    out += line;
    std::string points;
    for (size_t i = 0; i < image.points2d.size(); ++i) {
      if (i > 0) points += " ";
      points += Num(image.points2d[i].x()) + " " + Num(image.points2d[i].y()) + " " +
                (image.point3d_ids[i] == kColmapNoPoint3D ? std::string("-1")
                                                          : std::to_string(image.point3d_ids[i]));
    }
    out += points + "\n";
  }
  return out;
}

std::string Points3DText(const ColmapModel& model) {
  size_t track_sum = 0;
  for (const ColmapPoint3D& point : model.points3d) track_sum += point.track.size();
  const double mean_track = model.points3d.empty()
                                ? 0.0
                                : static_cast<double>(track_sum) / static_cast<double>(model.points3d.size());
  std::string out = "# 3D point list with one line of data per point:\n";
  out += "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n";
  out += "# Number of points: " + std::to_string(model.points3d.size()) +
         ", mean track length: " + Num(mean_track) + "\n";
  for (const ColmapPoint3D& point : model.points3d) {
    std::string line = std::to_string(point.id);
    for (int i = 0; i < 3; ++i) line += " " + Num(point.xyz[i]);
    for (int i = 0; i < 3; ++i) line += " " + std::to_string(static_cast<int>(point.rgb[i]));
    line += " " + Num(point.error);
    for (const ColmapTrackElement& element : point.track)
      line += " " + std::to_string(element.image_id) + " " + std::to_string(element.point2d_idx);
    out += line + "\n";
  }
  return out;
}

std::string RigsText(const ColmapModel& model) {
  std::string out = "# Rig calib list with one line of data per calib:\n";
  out +=
      "#   RIG_ID, NUM_SENSORS, REF_SENSOR_TYPE, REF_SENSOR_ID, SENSORS[] as (SENSOR_TYPE, SENSOR_ID, "
      "HAS_POSE, "
      "[QW, QX, QY, QZ, TX, TY, TZ])\n";
  out += "# Number of rigs: " + std::to_string(model.rigs.size()) + "\n";
  for (const ColmapRig& rig : model.rigs) {
    std::string line = std::to_string(rig.id) + " " + std::to_string(rig.sensors.size() + 1) + " " +
                       std::string(colmap_internal::kSensorCameraName) + " " +
                       std::to_string(rig.ref_camera_id);
    for (const ColmapRigSensor& sensor : rig.sensors) {
      line += " " + std::string(colmap_internal::kSensorCameraName) + " " + std::to_string(sensor.camera_id);
      if (sensor.sensor_from_rig) {
        line += " 1";
        AppendPose(*sensor.sensor_from_rig, &line);
      } else {
        line += " 0";
      }
    }
    out += line + "\n";
  }
  return out;
}

std::string FramesText(const ColmapModel& model) {
  std::string out = "# Frame list with one line of data per frame:\n";
  out +=
      "#   FRAME_ID, RIG_ID, RIG_FROM_WORLD[QW, QX, QY, QZ, TX, TY, TZ], NUM_DATA_IDS, DATA_IDS[] as "
      "(SENSOR_TYPE, SENSOR_ID, DATA_ID)\n";
  out += "# Number of frames: " + std::to_string(model.frames.size()) + "\n";
  for (const ColmapFrame& frame : model.frames) {
    std::string line = std::to_string(frame.id) + " " + std::to_string(frame.rig_id);
    AppendPose(frame.rig_from_world, &line);
    line += " " + std::to_string(frame.data.size());
    for (const ColmapFrameData& data : frame.data) {
      line += " " + std::string(colmap_internal::kSensorCameraName) + " " + std::to_string(data.camera_id) +
              " " + std::to_string(data.image_id);
    }
    out += line + "\n";
  }
  return out;
}

// Reads the lines of a text file; `Next` skips blank and comment lines.
class TextLines {
 public:
  explicit TextLines(fs::path path) : path_(std::move(path)), text_(ReadFileToString(path_)) {}

  // The next line that is neither empty nor a comment; false at the end.
  bool Next(std::string_view* line) {
    while (Raw(line)) {
      if (!line->empty() && line->front() != '#') return true;
    }
    return false;
  }
  // The very next line, whatever it holds; false at the end of the file.
  bool Raw(std::string_view* line) {
    if (pos_ >= text_.size()) return false;
    size_t end = text_.find('\n', pos_);
    if (end == std::string::npos) end = text_.size();
    *line = Trim(std::string_view(text_).substr(pos_, end - pos_));
    pos_ = end + 1;
    ++line_number_;
    return true;
  }
  [[noreturn]] void Fail(const std::string& message) const {
    MCVO_THROW_INPUT(path_.string(), ":", line_number_, ": ", message);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
  std::string text_;
  size_t pos_ = 0;
  int line_number_ = 0;
};

// Token cursor over one line, with typed reads that fail naming the field.
class Tokens {
 public:
  Tokens(const TextLines& lines, std::string_view line) : lines_(lines), tokens_(SplitTokens(line)) {}

  bool Done() const { return index_ >= tokens_.size(); }
  size_t Left() const { return tokens_.size() - index_; }
  std::string_view Word(const char* field) {
    if (Done()) lines_.Fail(StrCat(field, ": missing"));
    return tokens_[index_++];
  }
  uint64_t Uint(const char* field, uint64_t max) {
    const std::string_view word = Word(field);
    const std::optional<int64_t> value = ParseInt64(word);
    if (!value || *value < 0 || static_cast<uint64_t>(*value) > max)
      lines_.Fail(StrCat(field, ": expected an integer in [0, ", max, "], got '", word, "'"));
    return static_cast<uint64_t>(*value);
  }
  double Real(const char* field) {
    const std::string_view word = Word(field);
    const std::optional<double> value = ParseDouble(word);
    if (!value || !std::isfinite(*value))
      lines_.Fail(StrCat(field, ": expected a finite number, got '", word, "'"));
    return *value;
  }
  Rigid3d Pose(const char* field) {
    Rigid3d pose;
    const double w = Real(field), x = Real(field), y = Real(field), z = Real(field);
    pose.rotation = Eigen::Quaterniond(w, x, y, z);  // as read, not renormalised
    for (int i = 0; i < 3; ++i) pose.translation[i] = Real(field);
    return pose;
  }
  void Sensor(const char* field) {
    const std::string_view word = Word(field);
    if (word != colmap_internal::kSensorCameraName)
      lines_.Fail(StrCat(field, ": only CAMERA sensors are supported, got '", word, "'"));
  }
  void End() {
    if (!Done()) lines_.Fail(StrCat("unexpected '", tokens_[index_], "' at the end of the line"));
  }

 private:
  const TextLines& lines_;
  std::vector<std::string_view> tokens_;
  size_t index_ = 0;
};

constexpr uint64_t kMaxU32 = std::numeric_limits<uint32_t>::max();
constexpr uint64_t kMaxI64 = static_cast<uint64_t>(std::numeric_limits<int64_t>::max());

void ReadCamerasText(const fs::path& path, ColmapModel* model) {
  TextLines lines(path);
  std::string_view line;
  while (lines.Next(&line)) {
    Tokens tokens(lines, line);
    ColmapCamera camera;
    camera.id = static_cast<uint32_t>(tokens.Uint("CAMERA_ID", kMaxU32));
    const std::string_view model_name = tokens.Word("MODEL");
    const std::optional<ColmapCameraModel> camera_model = ColmapCameraModelFromName(model_name);
    if (!camera_model) lines.Fail(StrCat("MODEL: unknown camera model '", model_name, "'"));
    camera.model = *camera_model;
    camera.width = tokens.Uint("WIDTH", kMaxI64);
    camera.height = tokens.Uint("HEIGHT", kMaxI64);
    while (!tokens.Done()) camera.params.push_back(tokens.Real("PARAMS"));
    if (static_cast<int>(camera.params.size()) != ColmapCameraModelNumParams(camera.model)) {
      lines.Fail(StrCat("PARAMS: ", model_name, " has ", ColmapCameraModelNumParams(camera.model),
                        " parameters, got ", camera.params.size()));
    }
    model->cameras.push_back(std::move(camera));
  }
}

void ReadImagesText(const fs::path& path, ColmapModel* model) {
  TextLines lines(path);
  std::string_view line;
  while (lines.Next(&line)) {
    Tokens tokens(lines, line);
    ColmapImage image;
    image.id = static_cast<uint32_t>(tokens.Uint("IMAGE_ID", kMaxU32));
    image.cam_from_world = tokens.Pose("QW QX QY QZ TX TY TZ");
    image.camera_id = static_cast<uint32_t>(tokens.Uint("CAMERA_ID", kMaxU32));
    image.name = std::string(tokens.Word("NAME"));
    tokens.End();
    std::string_view points_line;
    if (!lines.Raw(&points_line)) lines.Fail(StrCat("image ", image.id, ": missing the POINTS2D line"));
    Tokens points(lines, points_line);
    if (points.Left() % 3 != 0) lines.Fail("POINTS2D: expected triplets X Y POINT3D_ID");
    while (!points.Done()) {
      const double x = points.Real("X");
      const double y = points.Real("Y");
      const std::string_view id_word = points.Word("POINT3D_ID");
      uint64_t id = kColmapNoPoint3D;
      if (id_word != "-1") {
        const std::optional<int64_t> value = ParseInt64(id_word);
        if (!value || *value < 0) lines.Fail(StrCat("POINT3D_ID: expected -1 or an id, got '", id_word, "'"));
        id = static_cast<uint64_t>(*value);
      }
      image.points2d.emplace_back(x, y);
      image.point3d_ids.push_back(id);
    }
    model->images.push_back(std::move(image));
  }
}

void ReadPoints3DText(const fs::path& path, ColmapModel* model) {
  TextLines lines(path);
  std::string_view line;
  while (lines.Next(&line)) {
    Tokens tokens(lines, line);
    ColmapPoint3D point;
    point.id = tokens.Uint("POINT3D_ID", kMaxI64);
    for (int i = 0; i < 3; ++i) point.xyz[i] = tokens.Real("X Y Z");
    for (int i = 0; i < 3; ++i) point.rgb[i] = static_cast<uint8_t>(tokens.Uint("R G B", 255));
    point.error = tokens.Real("ERROR");
    if (tokens.Left() % 2 != 0) lines.Fail("TRACK: expected pairs IMAGE_ID POINT2D_IDX");
    while (!tokens.Done()) {
      ColmapTrackElement element;
      element.image_id = static_cast<uint32_t>(tokens.Uint("IMAGE_ID", kMaxU32));
      element.point2d_idx = static_cast<uint32_t>(tokens.Uint("POINT2D_IDX", kMaxU32));
      point.track.push_back(element);
    }
    model->points3d.push_back(std::move(point));
  }
}

void ReadRigsText(const fs::path& path, ColmapModel* model) {
  TextLines lines(path);
  std::string_view line;
  while (lines.Next(&line)) {
    Tokens tokens(lines, line);
    ColmapRig rig;
    rig.id = static_cast<uint32_t>(tokens.Uint("RIG_ID", kMaxU32));
    const uint64_t num_sensors = tokens.Uint("NUM_SENSORS", kMaxU32);
    if (num_sensors == 0) lines.Fail("NUM_SENSORS: a rig without sensors is not supported");
    tokens.Sensor("REF_SENSOR_TYPE");
    rig.ref_camera_id = static_cast<uint32_t>(tokens.Uint("REF_SENSOR_ID", kMaxU32));
    for (uint64_t i = 1; i < num_sensors; ++i) {
      ColmapRigSensor sensor;
      tokens.Sensor("SENSOR_TYPE");
      sensor.camera_id = static_cast<uint32_t>(tokens.Uint("SENSOR_ID", kMaxU32));
      if (tokens.Uint("HAS_POSE", 1) == 1) sensor.sensor_from_rig = tokens.Pose("QW QX QY QZ TX TY TZ");
      rig.sensors.push_back(sensor);
    }
    tokens.End();
    model->rigs.push_back(std::move(rig));
  }
}

void ReadFramesText(const fs::path& path, ColmapModel* model) {
  TextLines lines(path);
  std::string_view line;
  while (lines.Next(&line)) {
    Tokens tokens(lines, line);
    ColmapFrame frame;
    frame.id = static_cast<uint32_t>(tokens.Uint("FRAME_ID", kMaxU32));
    frame.rig_id = static_cast<uint32_t>(tokens.Uint("RIG_ID", kMaxU32));
    frame.rig_from_world = tokens.Pose("QW QX QY QZ TX TY TZ");
    const uint64_t num_data = tokens.Uint("NUM_DATA_IDS", kMaxU32);
    for (uint64_t i = 0; i < num_data; ++i) {
      ColmapFrameData data;
      tokens.Sensor("SENSOR_TYPE");
      data.camera_id = static_cast<uint32_t>(tokens.Uint("SENSOR_ID", kMaxU32));
      data.image_id = tokens.Uint("DATA_ID", kMaxI64);
      frame.data.push_back(data);
    }
    tokens.End();
    model->frames.push_back(std::move(frame));
  }
}

}  // namespace

void WriteColmapModelText(const ColmapModel& model, const fs::path& dir) {
  colmap_internal::CheckWritableModel(model);
  CreateDirectories(dir);
  WriteFileAtomic(dir / "cameras.txt", CamerasText(model));
  WriteFileAtomic(dir / "images.txt", ImagesText(model));
  WriteFileAtomic(dir / "points3D.txt", Points3DText(model));
  if (!model.rigs.empty()) {
    WriteFileAtomic(dir / "rigs.txt", RigsText(model));
    WriteFileAtomic(dir / "frames.txt", FramesText(model));
  }
}

ColmapModel ReadColmapModelText(const fs::path& dir) {
  ColmapModel model;
  ReadCamerasText(dir / "cameras.txt", &model);
  ReadImagesText(dir / "images.txt", &model);
  ReadPoints3DText(dir / "points3D.txt", &model);
  std::error_code ec;
  if (fs::exists(dir / "rigs.txt", ec)) ReadRigsText(dir / "rigs.txt", &model);
  if (fs::exists(dir / "frames.txt", ec)) ReadFramesText(dir / "frames.txt", &model);
  colmap_internal::FinishReadModel(dir, ".txt", &model);
  return model;
}

}  // namespace mcvo
