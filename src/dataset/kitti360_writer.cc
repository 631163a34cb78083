// WriteKitti360Layout (mcvo/dataset/kitti360_writer.h).
#include "mcvo/dataset/kitti360_writer.h"

#include <algorithm>
#include <cctype>
#include <map>
#include <system_error>

#include <opencv2/imgcodecs.hpp>

#include "kitti360_calib.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

// The published rectifying rotations (../shared/reference/kitti360.md). The
// writer composes pose_from_cam with the same projected values the reader uses.
constexpr const char* kRectRotation00 =
    "0.999974 -0.007141 -0.000089 0.007141 0.999969 -0.003247 0.000112 0.003247 0.999995";
constexpr const char* kRectRotation01 =
    "0.999837 0.004862 -0.017390 -0.004974 0.999967 -0.006389 0.017358 0.006474 0.999828";

Eigen::Matrix3d ParseRectRotation(const char* text) {
  Eigen::Matrix3d m;
  const std::vector<std::string_view> fields = SplitTokens(text);
  MCVO_CHECK(fields.size() == 9);
  for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = *ParseDouble(fields[static_cast<size_t>(i)]);
  return kitti360::ProjectRotation(m, "R_rect");
}

std::string Numbers(const std::vector<double>& values) {
  std::string out;
  for (const double value : values) out += (out.empty() ? "" : " ") + FormatDouble(value);
  return out;
}

std::string Matrix3x4Text(const Eigen::Matrix<double, 3, 4>& m) {
  std::vector<double> values;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) values.push_back(m(r, c));
  }
  return Numbers(values);
}

void CheckRig(const Rig& rig, const fs::path& root) {
  if (rig.NumCameras() == 0) MCVO_THROW_INPUT(root.string(), ": KITTI-360 layout: the rig has no camera");
  for (const Camera& camera : rig.cameras) {
    if (!kitti360::IsKnownCamera(camera.name)) {
      MCVO_THROW_INPUT(root.string(), ": KITTI-360 layout: camera '", camera.name,
                       "' must be named image_00, image_01 (pinhole) or image_02, image_03 (mei)");
    }
    const CameraModelId expected =
        kitti360::IsPerspective(camera.name) ? CameraModelId::kPinhole : CameraModelId::kMei;
    if (camera.model != expected) {
      MCVO_THROW_INPUT(root.string(), ": KITTI-360 layout: camera ", camera.name, " must be ",
                       CameraModelName(expected), ", is ", CameraModelName(camera.model));
    }
    const std::string error = CameraParamsError(camera.model, camera.params);
    if (!error.empty())
      MCVO_THROW_INPUT(root.string(), ": KITTI-360 layout: camera ", camera.name, ": ", error);
  }
  if (rig.FindCamera("image_01") >= 0 && rig.FindCamera("image_00") < 0) {
    MCVO_THROW_INPUT(root.string(),
                     ": KITTI-360 layout: image_01 needs image_00 (P_rect_01 is relative to it)");
  }
}

// Copies a PNG byte for byte (other formats are re-encoded), via a temporary name.
void WriteImage(const fs::path& from, const fs::path& to) {
  const fs::path tmp = to.string() + ".tmp";
  std::string extension = from.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  std::error_code ec;
  if (extension == ".png") {
    fs::copy_file(from, tmp, fs::copy_options::overwrite_existing, ec);
    if (ec) MCVO_THROW_INPUT(from.string(), ": cannot copy to ", tmp.string(), ": ", ec.message());
  } else {
    const cv::Mat image = cv::imread(from.string(), cv::IMREAD_UNCHANGED);
    if (image.empty()) MCVO_THROW_INPUT(from.string(), ": cannot decode the image");
    if (!cv::imwrite(tmp.string(), image)) MCVO_THROW_INPUT(tmp.string(), ": cannot write the image");
  }
  fs::rename(tmp, to, ec);
  if (ec) MCVO_THROW_INPUT(to.string(), ": cannot rename from ", tmp.string(), ": ", ec.message());
}

void WriteMask(const cv::Mat& mask, const fs::path& to) {
  const fs::path tmp = to.string() + ".tmp.png";
  if (!cv::imwrite(tmp.string(), mask)) MCVO_THROW_INPUT(tmp.string(), ": cannot write the mask");
  std::error_code ec;
  fs::rename(tmp, to, ec);
  if (ec) MCVO_THROW_INPUT(to.string(), ": cannot rename from ", tmp.string(), ": ", ec.message());
}

}  // namespace

void WriteKitti360Layout(const DatasetIndex& source, const fs::path& root, const std::string& sequence) {
  if (sequence.empty() || sequence.find('/') != std::string::npos || sequence == "." || sequence == "..") {
    MCVO_THROW_INPUT(root.string(), ": KITTI-360 layout: invalid sequence name '", sequence, "'");
  }
  const Rig& rig = source.rig;
  CheckRig(rig, root);
  const fs::path calibration = root / "calibration";
  CreateDirectories(calibration);
  const Eigen::Matrix3d rect_00 = ParseRectRotation(kRectRotation00);
  const Eigen::Matrix3d rect_01 = ParseRectRotation(kRectRotation01);

  // Calibration, cameras in name order.
  std::string cam_to_pose, perspective;
  for (const std::string& name : kitti360::kCameraNames) {
    const int c = rig.FindCamera(name);
    if (c < 0) continue;
    const Camera& camera = rig.cameras[static_cast<size_t>(c)];
    const Rigid3d rig_from_cam = camera.cam_from_rig.Inverse();
    const std::string suffix = kitti360::CameraSuffix(name);
    Rigid3d pose_from_cam = rig_from_cam;
    if (name == "image_00") pose_from_cam = kitti360::PoseFromCam0(rig_from_cam, rect_00);
    if (name == "image_01") pose_from_cam = kitti360::PoseFromCam1(rig_from_cam, rect_00, rect_01);
    cam_to_pose += StrCat(name, ": ", Matrix3x4Text(pose_from_cam.ToMatrix3x4()), "\n");
    if (kitti360::IsPerspective(name)) {
      const std::vector<double>& p = camera.params;  // fx fy cx cy
      double fx_times_tx = 0.0;
      if (name == "image_01") {
        // P_rect_01[0,3] = fx * x of rect1_from_rect0 = -fx * baseline.
        const Camera& cam0 = rig.cameras[static_cast<size_t>(rig.FindCamera("image_00"))];
        fx_times_tx = p[0] * (camera.cam_from_rig * cam0.cam_from_rig.Inverse()).translation.x();
      }
      perspective += StrCat("S_rect_", suffix, ": ", camera.width, " ", camera.height, "\n");
      perspective +=
          StrCat("R_rect_", suffix, ": ", suffix == "00" ? kRectRotation00 : kRectRotation01, "\n");
      perspective += StrCat("P_rect_", suffix, ": ",
                            Numbers({p[0], 0, p[2], fx_times_tx, 0, p[1], p[3], 0, 0, 0, 1, 0}), "\n");
    } else {
      WriteFileAtomic(calibration / (name + ".yaml"), kitti360::MeiYamlText(camera));
      if (static_cast<size_t>(c) < source.masks.size() && !source.masks[static_cast<size_t>(c)].empty()) {
        WriteMask(source.masks[static_cast<size_t>(c)], calibration / ("mask_" + suffix + ".png"));
      }
    }
  }
  WriteFileAtomic(calibration / "calib_cam_to_pose.txt", cam_to_pose);
  if (!perspective.empty()) WriteFileAtomic(calibration / "perspective.txt", perspective);

  // Images and timestamps; frame i of the source is frame index i.
  std::string timestamps;
  for (const DatasetFrame& frame : source.frames) timestamps += kitti360::FormatTimestamp(frame.t_ns) + "\n";
  for (size_t c = 0; c < rig.cameras.size(); ++c) {
    const std::string& name = rig.cameras[c].name;
    const fs::path folder = kitti360::CameraFolder(root, sequence, name);
    const fs::path image_folder = folder / kitti360::ImageSubfolder(name);
    CreateDirectories(image_folder);
    for (size_t i = 0; i < source.frames.size(); ++i) {
      const DatasetFrame& frame = source.frames[i];
      MCVO_CHECK(frame.images.size() == rig.cameras.size());
      if (frame.images[c].empty()) continue;
      WriteImage(frame.images[c], image_folder / kitti360::ImageFileName(static_cast<int64_t>(i)));
    }
    WriteFileAtomic(folder / "timestamps.txt", timestamps);
  }

  // Ground truth at frame times, under the frame's index.
  if (source.ground_truth) {
    std::map<int64_t, int64_t> frame_of_time;
    for (size_t i = 0; i < source.frames.size(); ++i)
      frame_of_time[source.frames[i].t_ns] = static_cast<int64_t>(i);
    std::string poses;
    for (const StampedPose& pose : source.ground_truth->poses) {
      int64_t frame_index = -1;
      if (source.ground_truth->has_time) {
        const auto it = frame_of_time.find(pose.t_ns);
        if (it != frame_of_time.end()) frame_index = it->second;
      } else if (source.ground_truth->has_frame_index) {
        frame_index = pose.frame_index;
      }
      if (frame_index < 0) continue;
      poses += StrCat(frame_index, " ", Matrix3x4Text(pose.world_from_body.ToMatrix3x4()), "\n");
    }
    CreateDirectories(root / "data_poses" / sequence);
    WriteFileAtomic(root / "data_poses" / sequence / "poses.txt", poses);
  }
}

}  // namespace mcvo
