// The generic rig dataset (docs/dataset-format.md): rig.json, frames.csv,
// images/, optional masks and groundtruth.tum.
#include <map>
#include <system_error>
#include <utility>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "mcvo/dataset/dataset.h"
#include "mcvo/io/frame_table.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"
#include "rig_mask.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

std::string JoinNames(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& name : names) out += (out.empty() ? "" : ", ") + EscapeForMessage(name);
  return out;
}

bool IsFile(const fs::path& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

// "SEQ" for "/data/SEQ" and "/data/SEQ/".
std::string FolderName(const fs::path& root) {
  fs::path normal = root.lexically_normal();
  if (normal.filename().empty()) normal = normal.parent_path();
  std::string name = normal.filename().string();
  if (name.empty() || name == ".") name = fs::absolute(root).lexically_normal().filename().string();
  return name;
}

// Indices into the rig (and frames.csv columns) of the selected cameras.
std::vector<int> SelectCameras(const Rig& rig, const std::vector<std::string>& wanted,
                               const fs::path& rig_path) {
  std::vector<int> order;
  if (wanted.empty()) {
    for (int c = 0; c < rig.NumCameras(); ++c) order.push_back(c);
    return order;
  }
  for (const std::string& name : wanted) {
    const int c = rig.FindCamera(name);
    if (c < 0) {
      std::vector<std::string> names;
      for (const Camera& camera : rig.cameras) names.push_back(camera.name);
      throw UsageError(StrCat("cameras: '", EscapeForMessage(name), "' is not a camera of ",
                              rig_path.string(), " (cameras: ", JoinNames(names), ")"));
    }
    order.push_back(c);
  }
  return order;
}

}  // namespace

cv::Mat dataset_internal::ReadRigMask(const Camera& camera) {
  const fs::path path = camera.mask_path;
  if (!IsFile(path))
    MCVO_THROW_INPUT(path.string(), ": mask of camera ", camera.name, " (named in rig.json) is missing");
  cv::Mat mask;
  try {
    mask = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    MCVO_THROW_INPUT(path.string(), ": cannot decode mask image: ", e.what());
  }
  if (mask.empty()) MCVO_THROW_INPUT(path.string(), ": cannot decode mask image");
  if (mask.cols != camera.width || mask.rows != camera.height) {
    MCVO_THROW_INPUT(path.string(), ": mask is ", mask.cols, " x ", mask.rows, " px but camera ", camera.name,
                     " is ", camera.width, " x ", camera.height);
  }
  // Any non-zero value is valid: 255 exactly, whatever the file held.
  cv::Mat binary;
  cv::threshold(mask, binary, 0, 255, cv::THRESH_BINARY);
  return binary;
}

DatasetIndex ReadGenericDataset(const DatasetOptions& options) {
  const fs::path& root = options.root;
  const fs::path rig_path = root / "rig.json";
  const fs::path frames_path = root / "frames.csv";
  if (!IsFile(rig_path))
    MCVO_THROW_INPUT(rig_path.string(), ": missing (a generic dataset has rig.json and frames.csv)");
  if (!IsFile(frames_path)) {
    MCVO_THROW_INPUT(frames_path.string(), ": missing (a generic dataset has rig.json and frames.csv)");
  }
  const Rig full_rig = ReadRig(rig_path);
  const FrameTable table = ReadFrameTable(frames_path);
  if (table.rows.empty()) MCVO_THROW_INPUT(frames_path.string(), ": no frame (the header and no row)");

  std::vector<std::string> rig_names;
  for (const Camera& camera : full_rig.cameras) rig_names.push_back(camera.name);
  if (table.camera_names != rig_names) {
    MCVO_THROW_INPUT(frames_path.string(), ":1: header cameras (", JoinNames(table.camera_names),
                     ") must equal the cameras of rig.json in order (", JoinNames(rig_names), ")");
  }
  const std::vector<int> order = SelectCameras(full_rig, options.cameras, rig_path);

  DatasetIndex index;
  index.format = "generic";
  index.name = FolderName(root);
  index.root = root;
  for (const int c : order) index.rig.cameras.push_back(full_rig.cameras[static_cast<size_t>(c)]);

  // Frames: every referenced image must exist; rows with a missing image
  // follow the policy.
  std::vector<int> missing_per_camera(order.size(), 0);
  int incomplete = 0;
  for (size_t r = 0; r < table.rows.size(); ++r) {
    const FrameTableRow& row = table.rows[r];
    DatasetFrame frame;
    frame.t_ns = row.t_ns;
    bool complete = true;
    for (size_t k = 0; k < order.size(); ++k) {
      const std::string& relative = row.image_paths[static_cast<size_t>(order[k])];
      if (relative.empty()) {
        frame.images.emplace_back();
        ++missing_per_camera[k];
        complete = false;
        continue;
      }
      const fs::path image = (root / relative).lexically_normal();
      if (!IsFile(image)) {
        const std::string why = WhyNotAFile(image);
        MCVO_THROW_INPUT(image.string(), ": image file ", why == "does not exist" ? "missing" : why,
                         " (referenced by ", frames_path.string(),
                         ", frame ", r, ", t_ns=", row.t_ns, ", camera ", index.rig.cameras[k].name, ")");
      }
      frame.images.push_back(image);
    }
    if (!complete) ++incomplete;
    if (complete || options.missing_images == MissingImagePolicy::kMarkMissing) {
      index.frames.push_back(std::move(frame));
    }
  }
  if (incomplete > 0) {
    std::string per_camera;
    for (size_t k = 0; k < order.size(); ++k) {
      if (missing_per_camera[k] == 0) continue;
      per_camera +=
          StrCat(per_camera.empty() ? "" : ", ", index.rig.cameras[k].name, ": ", missing_per_camera[k]);
    }
    index.log.push_back(StrCat(
        "frames.csv: ", incomplete, " of ", table.rows.size(), " frames miss an image (", per_camera, "); ",
        options.missing_images == MissingImagePolicy::kSkipFrame
            ? StrCat("policy skip-frame: ", incomplete, " frame(s) dropped")
            : StrCat("policy mark-missing: ", incomplete, " frame(s) kept with the camera marked missing")));
  }

  const fs::path gt_path = root / "groundtruth.tum";
  if (IsFile(gt_path)) {
    index.ground_truth = ReadTrajectory(gt_path, TrajectoryFormat::kTum);
    index.log.push_back(StrCat("groundtruth.tum: ", index.ground_truth->poses.size(), " poses"));
  }

  for (const Camera& camera : index.rig.cameras) {
    if (camera.mask_path.empty()) {
      index.masks.emplace_back();
    } else {
      index.masks.push_back(dataset_internal::ReadRigMask(camera));
    }
  }
  return index;
}

}  // namespace mcvo
