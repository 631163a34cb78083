// KITTI-360 reader: calibration/ + data_2d_raw/<seq>/image_0N/ + data_poses/<seq>/poses.txt
// into a DatasetIndex. Layout, composition of the rectified cameras,
// synchronisation and masks: docs/datasets.md ("KITTI-360").
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <system_error>

#include <opencv2/imgcodecs.hpp>

#include "kitti360_calib.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

bool IsDirectory(const fs::path& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

bool IsFile(const fs::path& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

// The sequence to read: the given one, or the only one under data_2d_raw/.
std::string ResolveSequence(const DatasetOptions& options, std::vector<std::string>* log) {
  const fs::path raw = options.root / "data_2d_raw";
  if (!IsDirectory(raw)) MCVO_THROW_INPUT(raw.string(), ": missing folder (KITTI-360 images)");
  if (!options.sequence.empty()) {
    if (!IsDirectory(raw / options.sequence)) {
      MCVO_THROW_INPUT((raw / options.sequence).string(), ": sequence folder does not exist");
    }
    return options.sequence;
  }
  std::vector<std::string> sequences;
  for (const fs::directory_entry& entry : fs::directory_iterator(raw)) {
    if (entry.is_directory()) sequences.push_back(entry.path().filename().string());
  }
  std::sort(sequences.begin(), sequences.end());
  if (sequences.size() != 1) {
    std::string names;
    for (const std::string& name : sequences) names += (names.empty() ? "" : ", ") + name;
    throw UsageError(StrCat("sequence: not given, and ", raw.string(), " holds ", sequences.size(),
                            " sequences (", names, "); give --sequence"));
  }
  log->push_back(StrCat("sequence: ", sequences.front(), " (the only one in ", raw.string(), ")"));
  return sequences.front();
}

// The selected cameras: options.cameras in their order, or every camera
// whose folder exists.
std::vector<std::string> SelectCameras(const DatasetOptions& options, const std::string& sequence,
                                       std::vector<std::string>* log) {
  if (!options.cameras.empty()) {
    for (const std::string& name : options.cameras) {
      if (!kitti360::IsKnownCamera(name)) {
        throw UsageError(StrCat("cameras: '", name,
                                "' is not a KITTI-360 camera (image_00, image_01, image_02, "
                                "image_03)"));
      }
    }
    return options.cameras;
  }
  std::vector<std::string> cameras;
  for (const std::string& name : kitti360::kCameraNames) {
    if (IsDirectory(kitti360::CameraFolder(options.root, sequence, name))) {
      cameras.push_back(name);
    } else {
      log->push_back(StrCat(name, ": no folder ",
                            kitti360::CameraFolder(options.root, sequence, name).string(),
                            ", camera not used"));
    }
  }
  if (cameras.empty()) {
    MCVO_THROW_INPUT((options.root / "data_2d_raw" / sequence).string(),
                     ": no camera folder (image_00..image_03)");
  }
  return cameras;
}

// A rectified perspective camera from perspective.txt (S_rect_0N, P_rect_0N).
Camera ReadRectifiedCamera(const kitti360::KeyValueFile& perspective, const std::string& name) {
  const std::string suffix = kitti360::CameraSuffix(name);
  const std::vector<double> size = perspective.Numbers("S_rect_" + suffix, 2);
  if (size[0] < 1 || size[1] < 1 || size[0] != std::floor(size[0]) || size[1] != std::floor(size[1]) ||
      size[0] > 1e6 || size[1] > 1e6) {
    MCVO_THROW_INPUT(perspective.path().string(), ": S_rect_", suffix, ": expected a positive integer size");
  }
  const std::vector<double> p = perspective.Numbers("P_rect_" + suffix, 12);
  Camera camera;
  camera.name = name;
  camera.model = CameraModelId::kPinhole;
  camera.width = static_cast<int>(size[0]);
  camera.height = static_cast<int>(size[1]);
  camera.params = {p[0], p[5], p[2], p[6]};
  const std::string error = CameraParamsError(camera.model, camera.params);
  if (!error.empty()) MCVO_THROW_INPUT(perspective.path().string(), ": P_rect_", suffix, ": ", error);
  return camera;
}

Rig ReadKitti360Rig(const fs::path& calibration, const std::vector<std::string>& names,
                    std::vector<std::string>* log) {
  const kitti360::KeyValueFile cam_to_pose(calibration / "calib_cam_to_pose.txt");
  bool any_perspective = false;
  for (const std::string& name : names) any_perspective = any_perspective || kitti360::IsPerspective(name);
  std::optional<kitti360::KeyValueFile> perspective;
  if (any_perspective) perspective.emplace(calibration / "perspective.txt");
  Rig rig;
  for (const std::string& name : names) {
    Camera camera;
    Rigid3d rig_from_cam;
    if (name == "image_00") {
      camera = ReadRectifiedCamera(*perspective, name);
      rig_from_cam = kitti360::RigFromRect0(kitti360::ReadPoseFromCam(cam_to_pose, name),
                                            kitti360::ReadRectRotation(*perspective, "R_rect_00"));
    } else if (name == "image_01") {
      camera = ReadRectifiedCamera(*perspective, name);
      const Eigen::Matrix3d rect_00 = kitti360::ReadRectRotation(*perspective, "R_rect_00");
      rig_from_cam = kitti360::RigFromRect1(kitti360::ReadPoseFromCam(cam_to_pose, name), rect_00,
                                            kitti360::ReadRectRotation(*perspective, "R_rect_01"));
      // P_rect_01[0,3] = -fx * baseline: compare with the extrinsics.
      if (cam_to_pose.Has("image_00")) {
        const Rigid3d rig_from_rect0 =
            kitti360::RigFromRect0(kitti360::ReadPoseFromCam(cam_to_pose, "image_00"), rect_00);
        const double baseline = (rig_from_rect0.Inverse() * rig_from_cam).translation.x();
        const double p_baseline = -perspective->Numbers("P_rect_01", 12)[3] / camera.params[0];
        if (std::abs(baseline - p_baseline) > 1e-3) {
          log->push_back(StrCat("warning: image_01 baseline ", FormatFixed(baseline, 6),
                                " m (calib_cam_to_pose.txt, R_rect) differs from P_rect_01's ",
                                FormatFixed(p_baseline, 6), " m"));
        }
      }
    } else {
      camera = kitti360::ReadMeiYaml(calibration / (name + ".yaml"), name);
      rig_from_cam = kitti360::ReadPoseFromCam(cam_to_pose, name);
    }
    camera.cam_from_rig = rig_from_cam.Inverse();
    rig.cameras.push_back(camera);
  }
  return rig;
}

// calibration/mask_0N.png when it exists, else (fisheyes) the valid image circle.
cv::Mat LoadOrMakeMask(const fs::path& calibration, const DatasetOptions& options, Camera* camera,
                       std::vector<std::string>* log) {
  const fs::path path = calibration / ("mask_" + kitti360::CameraSuffix(camera->name) + ".png");
  if (IsFile(path)) {
    cv::Mat mask;
    try {
      mask = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
    } catch (const cv::Exception&) {
      mask = cv::Mat();
    }
    if (mask.empty()) MCVO_THROW_INPUT(path.string(), ": cannot decode the mask image");
    if (mask.cols != camera->width || mask.rows != camera->height) {
      MCVO_THROW_INPUT(path.string(), ": mask is ", mask.cols, "x", mask.rows, ", the camera is ",
                       camera->width, "x", camera->height);
    }
    camera->mask_path = fs::absolute(path).lexically_normal().string();
    log->push_back(StrCat(camera->name, ": mask loaded from ", path.string()));
    return mask;
  }
  if (camera->model != CameraModelId::kMei) return cv::Mat();
  log->push_back(StrCat(camera->name, ": mask generated from the valid image circle (",
                        FormatDouble(options.fisheye_max_angle_deg), " deg); no ", path.string()));
  return ValidPixelMask(*camera, options.fisheye_max_angle_deg);
}

// The images and times of one camera.
struct CameraImages {
  std::map<int64_t, fs::path> images;  // frame index -> PNG
  std::vector<int64_t> times;          // per frame index (timestamps.txt)
};

CameraImages ListImages(const fs::path& root, const std::string& sequence, const Camera& camera) {
  const fs::path folder = kitti360::CameraFolder(root, sequence, camera.name);
  const fs::path image_folder = folder / kitti360::ImageSubfolder(camera.name);
  if (!IsDirectory(image_folder)) MCVO_THROW_INPUT(image_folder.string(), ": missing image folder");
  CameraImages out;
  out.times = kitti360::ReadTimestamps(folder / "timestamps.txt");
  for (const fs::directory_entry& entry : fs::directory_iterator(image_folder)) {
    const std::string file = entry.path().filename().string();
    if (file.size() != 14 || entry.path().extension() != ".png") continue;
    const std::optional<int64_t> index = ParseInt64(file.substr(0, 10));
    if (!index || *index < 0) continue;
    if (*index >= static_cast<int64_t>(out.times.size())) {
      MCVO_THROW_INPUT((folder / "timestamps.txt").string(), ": has ", out.times.size(), " times, but image ",
                       entry.path().string(), " exists");
    }
    out.images[*index] = entry.path();
  }
  for (const auto& [index, path] : out.images) kitti360::CheckPngFile(path, camera.width, camera.height);
  return out;
}

}  // namespace

DatasetIndex ReadKitti360Dataset(const DatasetOptions& options) {
  DatasetIndex index;
  index.format = "kitti360";
  index.root = options.root;
  const std::string sequence = ResolveSequence(options, &index.log);
  index.name = sequence;
  const std::vector<std::string> names = SelectCameras(options, sequence, &index.log);
  const fs::path calibration = options.root / "calibration";
  index.rig = ReadKitti360Rig(calibration, names, &index.log);
  ValidateRigCameraNames(index.rig, EscapeForMessage(calibration.string()),
                         [&](size_t i) { return index.rig.cameras[i].name; });
  for (Camera& camera : index.rig.cameras)
    index.masks.push_back(LoadOrMakeMask(calibration, options, &camera, &index.log));

  std::vector<CameraImages> cameras;
  for (const Camera& camera : index.rig.cameras)
    cameras.push_back(ListImages(options.root, sequence, camera));

  // Frames: the reference (first selected) camera's images, at its times.
  const int64_t tolerance_ns = std::llround(options.sync_tolerance_s * 1e9);
  const size_t num_cameras = cameras.size();
  std::vector<int> no_image(num_cameras, 0), out_of_sync(num_cameras, 0);
  int skipped = 0;
  for (const auto& [frame_index, reference_image] : cameras[0].images) {
    DatasetFrame frame;
    frame.t_ns = cameras[0].times[static_cast<size_t>(frame_index)];
    frame.images.push_back(reference_image);
    bool complete = true;
    for (size_t c = 1; c < num_cameras; ++c) {
      const auto it = cameras[c].images.find(frame_index);
      if (it == cameras[c].images.end()) {
        ++no_image[c];
        complete = false;
        frame.images.emplace_back();
      } else if (std::llabs(cameras[c].times[static_cast<size_t>(frame_index)] - frame.t_ns) > tolerance_ns) {
        ++out_of_sync[c];
        complete = false;
        frame.images.emplace_back();
      } else {
        frame.images.push_back(it->second);
      }
    }
    if (!complete && options.missing_images == MissingImagePolicy::kSkipFrame) {
      ++skipped;
      continue;
    }
    index.frames.push_back(std::move(frame));
  }
  const char* action =
      options.missing_images == MissingImagePolicy::kSkipFrame ? "skipped" : "marked missing";
  for (size_t c = 1; c < num_cameras; ++c) {
    const std::string& name = index.rig.cameras[c].name;
    if (no_image[c] > 0)
      index.log.push_back(StrCat(name, ": no image at ", no_image[c], " frame(s), ", action));
    if (out_of_sync[c] > 0) {
      index.log.push_back(StrCat(name, ": ", out_of_sync[c], " image(s) more than ",
                                 FormatDouble(options.sync_tolerance_s), " s from ",
                                 index.rig.cameras[0].name, "'s time, ", action));
    }
  }
  if (skipped > 0) index.log.push_back(StrCat("skipped ", skipped, " incomplete frame(s)"));
  int without_reference = 0;
  for (size_t c = 1; c < num_cameras; ++c) {
    for (const auto& entry : cameras[c].images) {
      if (cameras[0].images.count(entry.first) == 0) ++without_reference;
    }
  }
  if (without_reference > 0) {
    index.log.push_back(StrCat(without_reference, " image(s) of other cameras at frames without a ",
                               index.rig.cameras[0].name, " image (the reference camera) not used"));
  }
  index.log.push_back(StrCat(index.frames.size(), " frame(s), reference camera ", index.rig.cameras[0].name));

  // Ground truth: world_from_pose at the listed (sparse) frames, timed by image_00.
  const fs::path poses = options.root / "data_poses" / sequence / "poses.txt";
  if (IsFile(poses)) {
    Trajectory ground_truth = ReadTrajectory(poses, TrajectoryFormat::kKittiIndexed);
    fs::path times = kitti360::CameraFolder(options.root, sequence, "image_00") / "timestamps.txt";
    if (!IsFile(times)) times = kitti360::CameraFolder(options.root, sequence, names[0]) / "timestamps.txt";
    ApplyTimesFile(times, &ground_truth);
    index.log.push_back(StrCat("ground truth: ", ground_truth.poses.size(), " pose(s) from ", poses.string(),
                               ", times from ", times.string()));
    index.ground_truth = std::move(ground_truth);
  } else {
    index.log.push_back(StrCat("no ground truth (", poses.string(), " does not exist)"));
  }
  return index;
}

}  // namespace mcvo
