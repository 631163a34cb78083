// OpenDataset: options check, layout detection, dispatch to the per-layout
// readers, camera subset, and the final validation every layout shares.
#include "mcvo/dataset/dataset.h"

#include <cmath>
#include <set>
#include <system_error>
#include <utility>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

const std::vector<std::string>& KnownFormats() {
  static const std::vector<std::string> formats = {"auto",  "generic", "kitti360", "kitti",
                                                   "euroc", "kalibr",  "rosbag"};
  return formats;
}

std::string JoinNames(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& name : names) out += (out.empty() ? "" : ", ") + EscapeForMessage(name);
  return out;
}

std::vector<std::string> CameraNames(const Rig& rig) {
  std::vector<std::string> names;
  for (const Camera& camera : rig.cameras) names.push_back(camera.name);
  return names;
}

bool Exists(const fs::path& path) {
  std::error_code ec;
  return fs::exists(path, ec);
}

// A KITTI odometry root (sequences/) or sequence folder (calib.txt and an
// image_0 .. image_3 folder).
bool IsKittiOdometryFolder(const fs::path& root) {
  std::error_code ec;
  if (fs::is_directory(root / "sequences", ec)) return true;
  if (!fs::is_regular_file(root / "calib.txt", ec)) return false;
  for (const char* folder : {"image_0", "image_1", "image_2", "image_3"})
    if (fs::is_directory(root / folder, ec)) return true;
  return false;
}

// Reorders (and subsets) the cameras of an index by name, when the layout
// reader did not already do it.
void ApplyCameraSelection(const std::vector<std::string>& wanted, DatasetIndex* index) {
  if (wanted.empty() || CameraNames(index->rig) == wanted) return;
  std::vector<int> order;
  for (const std::string& name : wanted) {
    const int c = index->rig.FindCamera(name);
    if (c < 0) {
      throw UsageError(StrCat("cameras: '", EscapeForMessage(name), "' is not a camera of ",
                              index->root.string(), " (cameras: ", JoinNames(CameraNames(index->rig)), ")"));
    }
    order.push_back(c);
  }
  Rig rig;
  std::vector<cv::Mat> masks;
  for (const int c : order) {
    rig.cameras.push_back(index->rig.cameras[static_cast<size_t>(c)]);
    masks.push_back(static_cast<size_t>(c) < index->masks.size() ? index->masks[static_cast<size_t>(c)]
                                                                 : cv::Mat());
  }
  for (DatasetFrame& frame : index->frames) {
    std::vector<fs::path> images;
    images.reserve(order.size());
    for (const int c : order) {
      images.push_back(static_cast<size_t>(c) < frame.images.size() ? frame.images[static_cast<size_t>(c)]
                                                                    : fs::path());
    }
    frame.images = std::move(images);
  }
  index->rig = std::move(rig);
  index->masks = std::move(masks);
  index->log.push_back(StrCat("cameras selected: ", JoinNames(wanted)));
}

// The invariants every layout guarantees to the rest of the program. A
// violation is reported as bad input of the dataset (it comes from the data).
void Validate(DatasetIndex* index) {
  const std::string source = EscapeForMessage(index->root.string());
  if (index->rig.NumCameras() == 0) MCVO_THROW_INPUT(source, ": the dataset has no camera");
  // The readers check the names where they read them (rig.json, folders,
  // camchain keys); this keeps the guarantee for any layout added later.
  ValidateRigCameraNames(index->rig, source, [](size_t i) { return "camera " + std::to_string(i); });
  const size_t num_cameras = static_cast<size_t>(index->rig.NumCameras());
  if (index->masks.empty()) index->masks.resize(num_cameras);
  MCVO_CHECK_MSG(index->masks.size() == num_cameras, "reader returned ", index->masks.size(), " masks for ",
                 num_cameras, " cameras");
  // A frame without any image carries nothing to track.
  std::vector<DatasetFrame> kept;
  kept.reserve(index->frames.size());
  int empty_frames = 0;
  for (DatasetFrame& frame : index->frames) {
    MCVO_CHECK_MSG(frame.images.size() == num_cameras, "reader returned a frame with ", frame.images.size(),
                   " images for ", num_cameras, " cameras");
    bool any = false;
    for (const fs::path& image : frame.images) any = any || !image.empty();
    if (any) {
      kept.push_back(std::move(frame));
    } else {
      ++empty_frames;
    }
  }
  index->frames = std::move(kept);
  if (empty_frames > 0) {
    index->log.push_back(
        StrCat("dropped ", empty_frames, " frame(s) without any image of the selected cameras"));
  }
  for (size_t i = 1; i < index->frames.size(); ++i) {
    if (index->frames[i].t_ns <= index->frames[i - 1].t_ns) {
      MCVO_THROW_INPUT(source, ": frame times must increase strictly: frame ", i,
                       " at t_ns=", index->frames[i].t_ns, " follows t_ns=", index->frames[i - 1].t_ns);
    }
  }
  if (index->frames.empty()) MCVO_THROW_INPUT(source, ": the dataset has no usable frame");
}

}  // namespace

void DatasetOptions::Check() const {
  if (root.empty()) throw UsageError("root: the dataset folder is not set");
  bool known = false;
  for (const std::string& name : KnownFormats()) known = known || name == format;
  if (!known)
    throw UsageError(StrCat("format: unknown '", format, "' (known: ", JoinNames(KnownFormats()), ")"));
  std::set<std::string> seen;
  for (const std::string& name : cameras) {
    if (name.empty()) throw UsageError("cameras: empty camera name");
    if (!seen.insert(name).second)
      throw UsageError(StrCat("cameras: '", EscapeForMessage(name), "' is listed twice"));
  }
  if (!(std::isfinite(sync_tolerance_s) && sync_tolerance_s >= 0.0 && sync_tolerance_s <= 1.0)) {
    throw UsageError(StrCat("sync_tolerance_s: must be in [0, 1] s, got ", FormatDouble(sync_tolerance_s)));
  }
  const bool rosbag = format == "rosbag" || (format == "auto" && root.extension() == ".bag");
  if (!rosbag) {
    for (const auto& [flag, given] : {std::pair<const char*, bool>{"calib", !calib.empty()},
                                      {"topics", !topics.empty()},
                                      {"gt_topic", !gt_topic.empty()},
                                      {"gt_file", !gt_file.empty()}}) {
      if (given) throw UsageError(StrCat(flag, ": only for ROS bags (format rosbag, a *.bag file)"));
    }
  } else {
    if (calib.empty())
      throw UsageError("calib: a ROS bag needs its calibration (a Kalibr camchain.yaml or a rig.json)");
    if (!gt_topic.empty() && !gt_file.empty())
      throw UsageError("gt_topic, gt_file: give one ground truth, not both");
    std::set<std::string> named;
    for (const auto& [camera, topic] : topics) {
      if (camera.empty() || topic.empty())
        throw UsageError(StrCat("topics: expected camera=topic, got '", camera, "=", topic, "'"));
      if (!named.insert(camera).second)
        throw UsageError(StrCat("topics: camera '", camera, "' is listed twice"));
    }
  }
  if (!(fisheye_max_angle_deg > 0.0 && fisheye_max_angle_deg <= 180.0)) {
    throw UsageError(
        StrCat("fisheye_max_angle_deg: must be in (0, 180], got ", FormatDouble(fisheye_max_angle_deg)));
  }
}

std::string DetectDatasetFormat(const fs::path& root) {
  std::error_code ec;
  if (root.extension() == ".bag" && !fs::is_directory(root, ec)) return "rosbag";
  if (!fs::is_directory(root, ec)) MCVO_THROW_INPUT(root.string(), ": dataset folder ", WhyNotAFolder(root));
  if (Exists(root / "frames.csv") && Exists(root / "rig.json")) return "generic";
  if (Exists(root / "calibration") && Exists(root / "data_2d_raw")) return "kitti360";
  if (Exists(root / "mav0") || Exists(root / "cam0" / "data.csv")) return "euroc";
  if (IsKittiOdometryFolder(root)) return "kitti";
  for (const fs::directory_entry& entry : fs::directory_iterator(root, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("camchain", 0) == 0 &&
        (entry.path().extension() == ".yaml" || entry.path().extension() == ".yml"))
      return "kalibr";
  }
  if (Exists(root / "frames.csv") || Exists(root / "rig.json")) {
    MCVO_THROW_INPUT(root.string(), ": looks like a generic dataset but ",
                     Exists(root / "rig.json") ? "frames.csv" : "rig.json", " is missing");
  }
  MCVO_THROW_INPUT(
      root.string(),
      ": unknown dataset layout (expected rig.json + frames.csv, KITTI-360 calibration/ + "
      "data_2d_raw/, KITTI odometry sequences/ or calib.txt + image_0/, EuRoC mav0/ or cam0/data.csv, or a "
      "Kalibr camchain*.yaml); give --format");
}

DatasetIndex OpenDataset(const DatasetOptions& options) {
  options.Check();
  DatasetOptions resolved = options;
  if (resolved.format == "auto") resolved.format = DetectDatasetFormat(options.root);
  DatasetIndex index;
  if (resolved.format == "generic") {
    index = ReadGenericDataset(resolved);
  } else if (resolved.format == "kitti360") {
    index = ReadKitti360Dataset(resolved);
  } else if (resolved.format == "kitti") {
    index = ReadKittiOdometryDataset(resolved);
  } else if (resolved.format == "euroc") {
    index = ReadEurocDataset(resolved);
  } else if (resolved.format == "rosbag") {
    index = ReadRosbagDataset(resolved);
  } else {
    MCVO_CHECK(resolved.format == "kalibr");
    index = ReadKalibrDataset(resolved);
  }
  if (index.format.empty()) index.format = resolved.format;
  if (index.root.empty()) index.root = options.root;
  ApplyCameraSelection(options.cameras, &index);
  Validate(&index);
  return index;
}

cv::Mat ValidPixelMask(const Camera& camera, double max_angle_deg) {
  const bool limit_angle = max_angle_deg < 180.0;
  const double min_cos = std::cos(max_angle_deg * M_PI / 180.0);
  cv::Mat mask(camera.height, camera.width, CV_8UC1, cv::Scalar(255));
  bool any_invalid = false;
  for (int y = 0; y < camera.height; ++y) {
    auto* row = mask.ptr<uint8_t>(y);
    for (int x = 0; x < camera.width; ++x) {
      const std::optional<Eigen::Vector3d> bearing = camera.Unproject(Eigen::Vector2d(x, y));
      if (!bearing || (limit_angle && bearing->normalized().z() < min_cos)) {
        row[x] = 0;
        any_invalid = true;
      }
    }
  }
  return any_invalid ? mask : cv::Mat();
}

}  // namespace mcvo
