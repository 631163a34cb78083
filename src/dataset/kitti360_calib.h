// Private helpers of the KITTI-360 reader and writer: the calibration files
// (calib_cam_to_pose.txt, perspective.txt, image_02.yaml / image_03.yaml),
// the rectified-camera composition, timestamps.txt, and a cheap PNG check.
// Facts: ../shared/reference/kitti360.md; layout and conventions:
// docs/datasets.md ("KITTI-360").
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mcvo/camera/camera.h"
#include "mcvo/geometry/rigid3d.h"

namespace mcvo::kitti360 {

// The four cameras of the KITTI-360 rig, in the default order.
inline const std::array<std::string, 4> kCameraNames = {"image_00", "image_01", "image_02", "image_03"};

// image_00 / image_01: rectified perspective cameras (data_rect);
// image_02 / image_03: MEI fisheyes (data_rgb).
bool IsPerspective(const std::string& camera_name);
bool IsKnownCamera(const std::string& camera_name);
// "00" for "image_00".
std::string CameraSuffix(const std::string& camera_name);
// data_2d_raw/<sequence>/<camera>
std::filesystem::path CameraFolder(const std::filesystem::path& root, const std::string& sequence,
                                   const std::string& camera_name);
// data_rect (perspective) or data_rgb (fisheye), inside CameraFolder.
std::string ImageSubfolder(const std::string& camera_name);
// "%010d.png"
std::string ImageFileName(int64_t frame_index);

// A "KEY: v1 v2 ..." text file (calib_cam_to_pose.txt, perspective.txt).
// Values are parsed when asked for, so lines the reader does not use (such as
// perspective.txt's "calib_time: 09-Jan-2012 14:00:15") never fail.
class KeyValueFile {
 public:
  // Throws InputError "<path>: missing calibration file" or
  // "<path>:<line>: expected 'KEY: values'" (a non-blank line without a colon).
  explicit KeyValueFile(const std::filesystem::path& path);

  const std::filesystem::path& path() const { return path_; }
  bool Has(const std::string& key) const { return entries_.count(key) > 0; }
  // Exactly `count` finite numbers. Throws InputError "<path>: missing key
  // KEY" or "<path>:<line>: KEY: ...".
  std::vector<double> Numbers(const std::string& key, size_t count) const;

 private:
  struct Entry {
    int line = 0;
    std::string value;
  };
  std::filesystem::path path_;
  std::map<std::string, Entry> entries_;
};

// Checks that `m` is a rotation to kRigRotationTolerance (calibration prints
// 6 to 10 decimals) and projects it onto SO(3) with an SVD, the projection
// used for config/rigs/kitti360.json. Throws InputError "<where>: ...".
Eigen::Matrix3d ProjectRotation(const Eigen::Matrix3d& m, const std::string& where);

// pose_from_cam of calib_cam_to_pose.txt (key "image_0N"), rotation projected.
Rigid3d ReadPoseFromCam(const KeyValueFile& file, const std::string& camera_name);
// R_rect_0N of perspective.txt (9 numbers, row-major), projected.
Eigen::Matrix3d ReadRectRotation(const KeyValueFile& file, const std::string& key);

// The rectified cameras in the rig (pose) frame (docs/rig-json.md, "KITTI-360
// presets"): rig_from_rect0 = pose_from_cam0 * inverse(R_rect_00);
// rig_from_rect1 = pose_from_cam1 * R_rect_01 * inverse(R_rect_00).
Rigid3d RigFromRect0(const Rigid3d& pose_from_cam0, const Eigen::Matrix3d& rect_00);
Rigid3d RigFromRect1(const Rigid3d& pose_from_cam1, const Eigen::Matrix3d& rect_00,
                     const Eigen::Matrix3d& rect_01);
// Their inverses, for the writer.
Rigid3d PoseFromCam0(const Rigid3d& rig_from_rect0, const Eigen::Matrix3d& rect_00);
Rigid3d PoseFromCam1(const Rigid3d& rig_from_rect1, const Eigen::Matrix3d& rect_00,
                     const Eigen::Matrix3d& rect_01);

// image_02.yaml / image_03.yaml (OpenCV-style YAML: "%YAML:1.0" first line,
// some keys without a space after the colon; MEI model) into a camera (name,
// model, params xi k1 k2 p1 p2 gamma1 gamma2 u0 v0, size), read with yaml-cpp.
// Throws InputError "<path>: missing calibration file",
// "<path>:<line>: projection_parameters/gamma1: missing key", ...
Camera ReadMeiYaml(const std::filesystem::path& path, const std::string& camera_name);
// The same file's text, in the dataset's own quirky formatting.
std::string MeiYamlText(const Camera& camera);

// timestamps.txt: one "YYYY-MM-DD HH:MM:SS.fffffffff" (UTC) per line, line i
// = frame i, strictly increasing. Throws InputError "<path>:<line>: ...".
std::vector<int64_t> ReadTimestamps(const std::filesystem::path& path);
// t_ns as "YYYY-MM-DD HH:MM:SS.fffffffff" (UTC); inverse of ReadTimestamps.
std::string FormatTimestamp(int64_t t_ns);

// Reads only the first 33 and last 12 bytes of a PNG file: throws InputError
// naming the file when it is not a PNG, is truncated (does not end with the
// IEND chunk) or its size differs from width x height. No decoding.
void CheckPngFile(const std::filesystem::path& path, int width, int height);

}  // namespace mcvo::kitti360
