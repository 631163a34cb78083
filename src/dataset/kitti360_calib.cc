// KITTI-360 calibration files, timestamps and PNG checks (kitti360_calib.h).
#include "kitti360_calib.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <string_view>
#include <system_error>

#include "mcvo/io/rig_io.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"
#include "yaml_util.h"

namespace mcvo::kitti360 {
namespace {

namespace fs = std::filesystem;

void RequireFile(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) MCVO_THROW_INPUT(path.string(), ": missing calibration file");
}

// (year, month, day) of a day count since 1970-01-01 (proleptic Gregorian).
void CivilFromDays(int64_t days, int64_t* year, int64_t* month, int64_t* day) {
  days += 719468;
  const int64_t era = (days >= 0 ? days : days - 146096) / 146097;
  const int64_t day_of_era = days - era * 146097;
  const int64_t year_of_era =
      (day_of_era - day_of_era / 1460 + day_of_era / 36524 - day_of_era / 146096) / 365;
  const int64_t day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
  const int64_t mp = (5 * day_of_year + 2) / 153;
  *day = day_of_year - (153 * mp + 2) / 5 + 1;
  *month = mp < 10 ? mp + 3 : mp - 9;
  *year = year_of_era + era * 400 + (*month <= 2 ? 1 : 0);
}

int64_t FloorDiv(int64_t a, int64_t b) { return a / b - ((a % b != 0) && ((a < 0) != (b < 0)) ? 1 : 0); }

// The dataset's image_0N.yaml with a space after every key's colon: the
// files write some keys as "xi:2.21", which cv::FileStorage reads as a key
// and yaml-cpp as one string. Only a line's leading "key:" is touched.
std::string SpaceAfterKeyColons(const std::string& text) {
  std::string out;
  out.reserve(text.size() + 64);
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    end = end == std::string::npos ? text.size() : end + 1;
    const std::string_view line(text.data() + start, end - start);
    size_t i = line.find_first_not_of(' ');
    const size_t key_start = i;
    while (i < line.size() && (std::isalnum(static_cast<unsigned char>(line[i])) || line[i] == '_')) ++i;
    const bool is_key = key_start != std::string_view::npos && i > key_start && i + 1 < line.size() &&
                        line[i] == ':' && line[i + 1] != ' ' && line[i + 1] != '\n' && line[i + 1] != '\r';
    if (is_key) {
      out.append(line.substr(0, i + 1)).append(" ").append(line.substr(i + 1));
    } else {
      out.append(line);
    }
    start = end;
  }
  return out;
}

}  // namespace

bool IsPerspective(const std::string& camera_name) {
  return camera_name == "image_00" || camera_name == "image_01";
}

bool IsKnownCamera(const std::string& camera_name) {
  for (const std::string& name : kCameraNames) {
    if (name == camera_name) return true;
  }
  return false;
}

std::string CameraSuffix(const std::string& camera_name) {
  return camera_name.substr(camera_name.size() - 2);
}

fs::path CameraFolder(const fs::path& root, const std::string& sequence, const std::string& camera_name) {
  return root / "data_2d_raw" / sequence / camera_name;
}

std::string ImageSubfolder(const std::string& camera_name) {
  return IsPerspective(camera_name) ? "data_rect" : "data_rgb";
}

std::string ImageFileName(int64_t frame_index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%010lld.png", static_cast<long long>(frame_index));
  return name;
}

KeyValueFile::KeyValueFile(const fs::path& path) : path_(path) {
  RequireFile(path);
  const std::string content = ReadFileToString(path);
  int line_number = 0;
  size_t start = 0;
  while (start < content.size()) {
    size_t end = content.find('\n', start);
    if (end == std::string::npos) end = content.size();
    ++line_number;
    const std::string_view line = Trim(std::string_view(content).substr(start, end - start));
    start = end + 1;
    if (line.empty() || line.front() == '#') continue;
    const size_t colon = line.find(':');
    if (colon == std::string_view::npos || colon == 0) {
      MCVO_THROW_INPUT(path.string(), ":", line_number, ": expected 'KEY: values', got '", line, "'");
    }
    const std::string key(Trim(line.substr(0, colon)));
    if (entries_.count(key) > 0) {
      MCVO_THROW_INPUT(path.string(), ":", line_number, ": key ", key, " repeats line ", entries_[key].line);
    }
    entries_[key] = {line_number, std::string(Trim(line.substr(colon + 1)))};
  }
}

std::vector<double> KeyValueFile::Numbers(const std::string& key, size_t count) const {
  const auto it = entries_.find(key);
  if (it == entries_.end()) MCVO_THROW_INPUT(path_.string(), ": missing key ", key);
  const std::vector<std::string_view> fields = SplitTokens(it->second.value);
  const std::string where = StrCat(path_.string(), ":", it->second.line, ": ", key);
  if (fields.size() != count) MCVO_THROW_INPUT(where, ": expected ", count, " numbers, got ", fields.size());
  std::vector<double> values;
  for (size_t i = 0; i < fields.size(); ++i) {
    const std::optional<double> value = ParseDouble(fields[i]);
    if (!value || !std::isfinite(*value)) {
      MCVO_THROW_INPUT(where, ": value ", i + 1, ": expected a finite number, got '", fields[i], "'");
    }
    values.push_back(*value);
  }
  return values;
}

Eigen::Matrix3d ProjectRotation(const Eigen::Matrix3d& m, const std::string& where) {
  const double error = (m.transpose() * m - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (error > kRigRotationTolerance) {
    MCVO_THROW_INPUT(where, ": rotation is not orthonormal (max |R^T R - I| = ", FormatDouble(error),
                     ", tolerance ", FormatDouble(kRigRotationTolerance), ")");
  }
  if (m.determinant() <= 0.0)
    MCVO_THROW_INPUT(where, ": rotation has determinant ", FormatDouble(m.determinant()));
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

Rigid3d ReadPoseFromCam(const KeyValueFile& file, const std::string& camera_name) {
  const std::vector<double> v = file.Numbers(camera_name, 12);
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) rotation(r, c) = v[static_cast<size_t>(4) * r + c];
    translation(r) = v[static_cast<size_t>(4) * r + 3];
  }
  return Rigid3d(ProjectRotation(rotation, StrCat(file.path().string(), ": ", camera_name)), translation);
}

Eigen::Matrix3d ReadRectRotation(const KeyValueFile& file, const std::string& key) {
  const std::vector<double> v = file.Numbers(key, 9);
  const Eigen::Matrix3d m = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(v.data());
  return ProjectRotation(m, StrCat(file.path().string(), ": ", key));
}

Rigid3d RigFromRect0(const Rigid3d& pose_from_cam0, const Eigen::Matrix3d& rect_00) {
  // R_rect_00 maps raw cam0 coordinates to rectified ones: rect0_from_cam0.
  const Rigid3d cam0_from_rect0(Eigen::Matrix3d(rect_00.transpose()), Eigen::Vector3d::Zero());
  return pose_from_cam0 * cam0_from_rect0;
}

Rigid3d RigFromRect1(const Rigid3d& pose_from_cam1, const Eigen::Matrix3d& rect_00,
                     const Eigen::Matrix3d& rect_01) {
  // R_rect_01 is cam1_from_cam0 (docs/rig-json.md): the rectified cam1 shares
  // rect0's orientation, cam1_from_rect1 = R_rect_01 * inverse(R_rect_00).
  const Rigid3d cam1_from_rect1(Eigen::Matrix3d(rect_01 * rect_00.transpose()), Eigen::Vector3d::Zero());
  return pose_from_cam1 * cam1_from_rect1;
}

Rigid3d PoseFromCam0(const Rigid3d& rig_from_rect0, const Eigen::Matrix3d& rect_00) {
  return rig_from_rect0 * Rigid3d(rect_00, Eigen::Vector3d::Zero());
}

Rigid3d PoseFromCam1(const Rigid3d& rig_from_rect1, const Eigen::Matrix3d& rect_00,
                     const Eigen::Matrix3d& rect_01) {
  return rig_from_rect1 * Rigid3d(Eigen::Matrix3d(rect_00 * rect_01.transpose()), Eigen::Vector3d::Zero());
}

Camera ReadMeiYaml(const fs::path& path, const std::string& camera_name) {
  using namespace dataset_internal;
  RequireFile(path);
  // yaml-cpp, as the other YAML readers: cv::FileStorage's parser hangs or
  // throws std::length_error on some malformed files (found by
  // tests/fuzz/kitti360_mei_fuzz.cc: "%YAML:1.\n k:0\n %YAML:1.0\n:---\nm" never returns).
  const YamlFile file = ParseYamlText(path, SpaceAfterKeyColons(ReadFileToString(path)));
  Camera camera;
  camera.name = camera_name;
  camera.model = CameraModelId::kMei;
  CatchYamlErrors(file, [&] {
    if (const std::optional<YAML::Node> model = OptionalKey(file.root, "model_type")) {
      if (ReadString(file, *model, "model_type") != "MEI")
        ThrowYamlError(file, *model, "model_type", "expected MEI");
    }
    const YAML::Node width_node = RequiredKey(file, file.root, "", "image_width");
    const YAML::Node height_node = RequiredKey(file, file.root, "", "image_height");
    const double width = ReadDouble(file, width_node, "image_width");
    const double height = ReadDouble(file, height_node, "image_height");
    if (width < 1 || height < 1 || width != std::floor(width) || height != std::floor(height) ||
        width > 1e6 || height > 1e6) {
      ThrowYamlError(file, width_node, "image_width, image_height", "expected positive integers");
    }
    camera.width = static_cast<int>(width);
    camera.height = static_cast<int>(height);
    auto number = [&](const char* group, const char* key) {
      const YAML::Node map = RequiredKey(file, file.root, "", group);
      return ReadDouble(file, RequiredKey(file, map, group, key), JoinKey(group, key));
    };
    camera.params = {number("mirror_parameters", "xi"),         number("distortion_parameters", "k1"),
                     number("distortion_parameters", "k2"),     number("distortion_parameters", "p1"),
                     number("distortion_parameters", "p2"),     number("projection_parameters", "gamma1"),
                     number("projection_parameters", "gamma2"), number("projection_parameters", "u0"),
                     number("projection_parameters", "v0")};
  });
  const std::string error = CameraParamsError(camera.model, camera.params);
  if (!error.empty()) MCVO_THROW_INPUT(path.string(), ": ", error);
  return camera;
}

std::string MeiYamlText(const Camera& camera) {
  MCVO_CHECK(camera.model == CameraModelId::kMei && camera.params.size() == 9);
  const std::vector<double>& p = camera.params;
  // As the dataset's files: "%YAML:1.0", and some keys without a space after
  // the colon (ReadMeiYaml accepts both).
  return StrCat(
      "%YAML:1.0\n---\nmodel_type: MEI\ncamera_name: ", camera.name, "\nimage_width: ", camera.width,
      "\nimage_height: ", camera.height, "\nmirror_parameters:\n   xi:", FormatDouble(p[0]),
      "\ndistortion_parameters:\n   k1: ", FormatDouble(p[1]), "\n   k2: ", FormatDouble(p[2]),
      "\n   p1:", FormatDouble(p[3]), "\n   p2: ", FormatDouble(p[4]),
      "\nprojection_parameters:\n   gamma1: ", FormatDouble(p[5]), "\n   gamma2:", FormatDouble(p[6]),
      "\n   u0: ", FormatDouble(p[7]), "\n   v0: ", FormatDouble(p[8]), "\n");
}

std::vector<int64_t> ReadTimestamps(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) MCVO_THROW_INPUT(path.string(), ": missing timestamps file");
  // ApplyTimesFile parses and checks the times (file:line messages); give
  // it one pose per data line of the file.
  const std::string content = ReadFileToString(path);
  int64_t lines = 0;
  size_t start = 0;
  while (start < content.size()) {
    size_t end = content.find('\n', start);
    if (end == std::string::npos) end = content.size();
    const std::string_view line = Trim(std::string_view(content).substr(start, end - start));
    if (!line.empty() && line.front() != '#') ++lines;
    start = end + 1;
  }
  Trajectory frames;
  frames.has_frame_index = true;
  frames.poses.resize(static_cast<size_t>(lines));
  for (int64_t i = 0; i < lines; ++i) frames.poses[static_cast<size_t>(i)].frame_index = i;
  ApplyTimesFile(path, &frames);
  std::vector<int64_t> times;
  times.reserve(frames.poses.size());
  for (const StampedPose& pose : frames.poses) times.push_back(pose.t_ns);
  return times;
}

std::string FormatTimestamp(int64_t t_ns) {
  constexpr int64_t kNsPerDay = 86400LL * 1'000'000'000LL;
  const int64_t days = FloorDiv(t_ns, kNsPerDay);
  const int64_t ns_of_day = t_ns - days * kNsPerDay;
  int64_t year = 0, month = 0, day = 0;
  CivilFromDays(days, &year, &month, &day);
  const int64_t seconds = ns_of_day / 1'000'000'000LL;
  char text[64];
  std::snprintf(text, sizeof(text), "%04lld-%02lld-%02lld %02lld:%02lld:%02lld.%09lld",
                static_cast<long long>(year), static_cast<long long>(month), static_cast<long long>(day),
                static_cast<long long>(seconds / 3600), static_cast<long long>(seconds / 60 % 60),
                static_cast<long long>(seconds % 60), static_cast<long long>(ns_of_day % 1'000'000'000LL));
  return text;
}

void CheckPngFile(const fs::path& path, int width, int height) {
  std::ifstream in(path, std::ios::binary);
  if (!in) MCVO_THROW_INPUT(path.string(), ": cannot open image");
  unsigned char head[33] = {};
  in.read(reinterpret_cast<char*>(head), sizeof(head));
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (in.gcount() < static_cast<std::streamsize>(sizeof(head)) ||
      !std::equal(kSignature, kSignature + 8, head) ||
      std::string(reinterpret_cast<const char*>(head + 12), 4) != "IHDR") {
    MCVO_THROW_INPUT(path.string(), ": not a PNG image (bad or truncated header)");
  }
  auto be32 = [&](int offset) {
    return static_cast<int64_t>(head[offset]) << 24 | static_cast<int64_t>(head[offset + 1]) << 16 |
           static_cast<int64_t>(head[offset + 2]) << 8 | static_cast<int64_t>(head[offset + 3]);
  };
  const int64_t png_width = be32(16), png_height = be32(20);
  if (png_width != width || png_height != height) {
    MCVO_THROW_INPUT(path.string(), ": image is ", png_width, "x", png_height, ", the calibration says ",
                     width, "x", height);
  }
  // Every complete PNG ends with the 12-byte IEND chunk.
  static const unsigned char kIend[12] = {0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82};
  unsigned char tail[12] = {};
  in.seekg(-12, std::ios::end);
  in.read(reinterpret_cast<char*>(tail), sizeof(tail));
  if (!in || !std::equal(kIend, kIend + 12, tail)) {
    MCVO_THROW_INPUT(path.string(), ": truncated or corrupt PNG (no IEND chunk at the end)");
  }
}

}  // namespace mcvo::kitti360
