// EuRoC / ASL layout (docs/datasets.md, "EuRoC"):
//
//   <root>/mav0/camN/sensor.yaml      T_BS (body_from_sensor), intrinsics, distortion
//   <root>/mav0/camN/data.csv         "#timestamp [ns],filename"
//   <root>/mav0/camN/data/<filename>  the images
//   <root>/mav0/state_groundtruth_estimate0/data.csv   optional, world_from_body
//
// The rig frame is the body frame B of the dataset (the IMU): cam_from_rig =
// inverse(T_BS), and the ground truth (world_from_body) is world_from_rig.
// <root> may also be the mav0 folder itself.
#include <algorithm>
#include <cctype>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "camera_sync.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/util/error.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/strings.h"
#include "yaml_util.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;
using dataset_internal::CameraImages;
using dataset_internal::YamlFile;

// "cam12" -> 12, anything else -> -1.
int CameraNumber(const std::string& name) {
  if (name.size() < 4 || name.size() > 7 || name.compare(0, 3, "cam") != 0) return -1;
  // Digits only: ParseInt64 alone would take "cam0\n" or "cam0 " (it trims
  // blanks), and the folder name is the camera name, a path component of
  // the outputs.
  for (size_t i = 3; i < name.size(); ++i) {
    if (!std::isdigit(static_cast<unsigned char>(name[i]))) return -1;
  }
  const std::optional<int64_t> n = ParseInt64(std::string_view(name).substr(3));
  if (!n || *n < 0 || *n > 1000) return -1;
  return static_cast<int>(*n);
}

fs::path ResolveMav0(const fs::path& root) {
  std::error_code ec;
  if (!fs::is_directory(root, ec)) MCVO_THROW_INPUT(root.string(), ": dataset folder not found");
  if (fs::is_directory(root / "mav0", ec)) return root / "mav0";
  return root;
}

// The camN folders of mav0, in numeric order.
std::vector<std::string> ListCameraFolders(const fs::path& mav0) {
  std::vector<std::pair<int, std::string>> found;
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(mav0, ec)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_directory(ec) && CameraNumber(name) >= 0) found.emplace_back(CameraNumber(name), name);
  }
  if (ec) MCVO_THROW_INPUT(mav0.string(), ": cannot list folder: ", ec.message());
  std::sort(found.begin(), found.end());
  std::vector<std::string> names;
  names.reserve(found.size());
  for (const auto& [number, name] : found) names.push_back(name);
  if (names.empty()) MCVO_THROW_INPUT(mav0.string(), ": no camera folder (cam0, cam1, ...) found");
  return names;
}

Camera ReadSensorYaml(const fs::path& path, const std::string& name) {
  const YamlFile file = dataset_internal::LoadYamlFile(path);
  Camera camera;
  camera.name = name;
  dataset_internal::CatchYamlErrors(file, [&] {
    using namespace dataset_internal;
    const YAML::Node& root = file.root;
    if (const std::optional<YAML::Node> type = OptionalKey(root, "sensor_type")) {
      const std::string value = ReadString(file, *type, "sensor_type");
      if (value != "camera")
        ThrowYamlError(file, *type, "sensor_type", "expected 'camera', got '" + value + "'");
    }
    const YAML::Node t_bs = RequiredKey(file, root, "", "T_BS");
    const Rigid3d body_from_sensor = RigidFromMatrix4(file, t_bs, "T_BS", ReadMatrix4(file, t_bs, "T_BS"));
    camera.cam_from_rig = body_from_sensor.Inverse();

    const Eigen::Vector2i resolution =
        ReadResolution(file, RequiredKey(file, root, "", "resolution"), "resolution");
    camera.width = resolution.x();
    camera.height = resolution.y();
    if (const std::optional<YAML::Node> model = OptionalKey(root, "camera_model")) {
      const std::string value = ReadString(file, *model, "camera_model");
      if (value != "pinhole") {
        ThrowYamlError(file, *model, "camera_model",
                       "unsupported camera model '" + value + "' (supported: pinhole)");
      }
    }
    const YAML::Node intrinsics_node = RequiredKey(file, root, "", "intrinsics");
    std::vector<double> params = ReadDoubleList(file, intrinsics_node, "intrinsics", 4);  // fu fv cu cv

    const YAML::Node model_node = RequiredKey(file, root, "", "distortion_model");
    const std::string model = ReadString(file, model_node, "distortion_model");
    // Required unless the model is "none" (then absent or all zero).
    const bool distorted = model != "none" && model != "pinhole";
    const YAML::Node coeffs_node =
        distorted ? RequiredKey(file, root, "", "distortion_coefficients") : root["distortion_coefficients"];
    std::vector<double> coeffs;
    if (coeffs_node.IsDefined() && !coeffs_node.IsNull()) {
      coeffs = ReadDoubleList(file, coeffs_node, "distortion_coefficients");
    }
    if (model == "radial-tangential" || model == "radtan") {
      // k1 k2 p1 p2 [k3]
      if (coeffs.size() != 4 && coeffs.size() != 5) {
        ThrowYamlError(
            file, coeffs_node, "distortion_coefficients",
            StrCat("radial-tangential needs 4 (k1 k2 p1 p2) or 5 (with k3) numbers, got ", coeffs.size()));
      }
      coeffs.resize(5, 0.0);
      camera.model = CameraModelId::kRadTan;
    } else if (model == "equidistant") {
      if (coeffs.size() != 4) {
        ThrowYamlError(file, coeffs_node, "distortion_coefficients",
                       StrCat("equidistant needs 4 numbers (k1 k2 k3 k4), got ", coeffs.size()));
      }
      camera.model = CameraModelId::kKannalaBrandt;
    } else if (model == "none" || model == "pinhole") {
      if (std::any_of(coeffs.begin(), coeffs.end(), [](double c) { return c != 0.0; })) {
        ThrowYamlError(file, coeffs_node, "distortion_coefficients",
                       "distortion_model 'none' with non-zero coefficients");
      }
      coeffs.clear();
      camera.model = CameraModelId::kPinhole;
    } else {
      ThrowYamlError(file, model_node, "distortion_model",
                     "unsupported distortion model '" + model + "' (radial-tangential, equidistant, none)");
    }
    params.insert(params.end(), coeffs.begin(), coeffs.end());
    const std::string error = CameraParamsError(camera.model, params);
    if (!error.empty()) ThrowYamlError(file, intrinsics_node, "intrinsics", error);
    camera.params = std::move(params);
  });
  return camera;
}

// Reads camN/data.csv. Listed images that are not on disk are left out and
// counted in *absent (they become missing images of the frame).
CameraImages ReadDataCsv(const fs::path& folder, const std::string& name, size_t* absent,
                         std::string* first_absent) {
  const fs::path csv = folder / "data.csv";
  std::ifstream in(csv);
  if (!in) MCVO_THROW_INPUT(csv.string(), ": missing image list (cannot open)");
  CameraImages images;
  images.name = name;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string_view text = Trim(line);
    if (text.empty() || text[0] == '#') continue;
    const std::vector<std::string_view> fields = SplitFields(text, ',');
    if (fields.size() != 2 || fields[1].empty()) {
      MCVO_THROW_INPUT(csv.string(), ":", line_number, ": expected 'timestamp_ns,filename', got '", text,
                       "'");
    }
    const std::optional<int64_t> t_ns = ParseInt64(fields[0]);
    if (!t_ns || *t_ns < 0) {
      MCVO_THROW_INPUT(csv.string(), ":", line_number, ": time stamp '", fields[0],
                       "' is not a non-negative integer (ns)");
    }
    if (!images.t_ns.empty() && *t_ns <= images.t_ns.back()) {
      MCVO_THROW_INPUT(csv.string(), ":", line_number, ": time stamp ", *t_ns,
                       " does not increase (previous ", images.t_ns.back(),
                       "); time stamps must be strictly increasing");
    }
    const fs::path image = folder / "data" / std::string(fields[1]);
    std::error_code ec;
    if (!fs::is_regular_file(image, ec)) {
      if ((*absent)++ == 0) *first_absent = image.string();
      images.t_ns.push_back(*t_ns);  // keeps the monotonicity check on the listed times
      images.images.emplace_back();
      continue;
    }
    images.t_ns.push_back(*t_ns);
    images.images.push_back(image);
  }
  // Drop the absent images (kept above only for the order check).
  CameraImages present;
  present.name = name;
  for (size_t i = 0; i < images.t_ns.size(); ++i) {
    if (images.images[i].empty()) continue;
    present.t_ns.push_back(images.t_ns[i]);
    present.images.push_back(images.images[i]);
  }
  return present;
}

std::string SequenceName(const fs::path& root) {
  fs::path path = root.lexically_normal();
  if (path.filename().empty()) path = path.parent_path();
  if (path.filename() == "mav0" && path.has_parent_path()) path = path.parent_path();
  return path.filename().string();
}

}  // namespace

DatasetIndex ReadEurocDataset(const DatasetOptions& options) {
  const fs::path mav0 = ResolveMav0(options.root);
  const std::vector<std::string> available = ListCameraFolders(mav0);
  std::vector<std::string> selected = options.cameras.empty() ? available : options.cameras;
  for (const std::string& name : selected) {
    if (std::find(available.begin(), available.end(), name) == available.end()) {
      std::string list;
      for (const std::string& a : available) list += (list.empty() ? "" : ", ") + a;
      throw UsageError(StrCat("cameras: '", EscapeForMessage(name), "' is not a camera of ", mav0.string(),
                              " (cameras: ", list, ")"));
    }
  }

  DatasetIndex index;
  index.format = "euroc";
  index.name = SequenceName(options.root);
  index.root = options.root;
  std::vector<CameraImages> streams;
  for (const std::string& name : selected) {
    const fs::path folder = mav0 / name;
    index.rig.cameras.push_back(ReadSensorYaml(folder / "sensor.yaml", name));
    size_t absent = 0;
    std::string first_absent;
    streams.push_back(ReadDataCsv(folder, name, &absent, &first_absent));
    if (absent > 0) {
      index.log.push_back(StrCat(name, ": ", absent, " images listed in data.csv are not on disk (first: ",
                                 first_absent, "); treated as missing"));
    }
  }
  ValidateRigCameraNames(index.rig, EscapeForMessage(mav0.string()),
                         [&](size_t i) { return "camera folder " + std::to_string(i); });
  if (streams[0].t_ns.empty()) MCVO_THROW_INPUT((mav0 / selected[0] / "data.csv").string(), ": no images");
  index.log.push_back(
      StrCat("euroc: rig frame = body frame B (IMU); cam_from_rig = inverse(T_BS) of each sensor.yaml"));

  dataset_internal::SyncResult sync =
      dataset_internal::SynchronizeCameras(streams, options.sync_tolerance_s, options.missing_images);
  index.log.insert(index.log.end(), sync.log.begin(), sync.log.end());
  index.frames = std::move(sync.frames);
  if (index.frames.empty()) {
    MCVO_THROW_INPUT(mav0.string(), ": no frame has an image from every camera within ",
                     options.sync_tolerance_s, " s");
  }
  index.masks.assign(index.rig.cameras.size(), cv::Mat());

  const fs::path gt = mav0 / "state_groundtruth_estimate0" / "data.csv";
  std::error_code ec;
  if (fs::is_regular_file(gt, ec)) {
    index.ground_truth = ReadTrajectory(gt, TrajectoryFormat::kEuroc);
    index.log.push_back(StrCat("ground truth: ", gt.string(), " (", index.ground_truth->poses.size(),
                               " poses, world_from_body = world_from_rig)"));
  } else {
    index.log.push_back("ground truth: none (no state_groundtruth_estimate0/data.csv)");
  }
  for (const std::string& line : index.log) MCVO_LOG(kDebug, line);
  return index;
}

}  // namespace mcvo
