// Kalibr / MultiCamData layout (docs/datasets.md, "Kalibr"):
//
//   <root>/camchain.yaml (or the one file camchain*.yaml)
//       camN: camera_model, distortion_model, distortion_coeffs, intrinsics,
//             resolution, rostopic, T_cn_cnm1 (camN_from_cam(N-1), N >= 1),
//             optional T_cam_imu (camN_from_imu), optional cam_overlaps
//   <root>/camN/<timestamp_ns>.png
//   <root>/groundtruth.tum or <root>/groundtruth.csv   optional, world_from_rig
//
// Rig frame: cam0, or the IMU when cam0 has T_cam_imu (camchain-imucam
// files): cam_k_from_rig = T_k,k-1 * ... * T_1,0 * cam0_from_rig with
// cam0_from_rig = identity or T_cam_imu of cam0. The T_cam_imu of the other
// cameras are only compared with the chain (the difference is logged).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "camera_sync.h"
#include "kalibr_camchain.h"
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

fs::path FindCamchain(const fs::path& root) {
  std::error_code ec;
  if (!fs::is_directory(root, ec)) MCVO_THROW_INPUT(root.string(), ": dataset folder not found");
  if (fs::is_regular_file(root / "camchain.yaml", ec)) return root / "camchain.yaml";
  std::vector<fs::path> candidates;
  for (const fs::directory_entry& entry : fs::directory_iterator(root, ec)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_regular_file(ec) && name.rfind("camchain", 0) == 0 && entry.path().extension() == ".yaml") {
      candidates.push_back(entry.path());
    }
  }
  std::sort(candidates.begin(), candidates.end());
  if (candidates.empty()) {
    MCVO_THROW_INPUT((root / "camchain.yaml").string(), ": missing calibration file (no camchain*.yaml in ",
                     root.string(), ")");
  }
  if (candidates.size() > 1) {
    std::string list;
    for (const fs::path& c : candidates) list += (list.empty() ? "" : ", ") + c.filename().string();
    MCVO_THROW_INPUT(root.string(), ": several calibration files (", list,
                     "); copy the one to use to camchain.yaml");
  }
  return candidates[0];
}

// Camera model and parameters of one camchain entry.
void ReadIntrinsics(const YamlFile& file, const YAML::Node& cam, const std::string& key, Camera* camera) {
  using namespace dataset_internal;
  const std::string model_key = JoinKey(key, "camera_model");
  const YAML::Node model_node = RequiredKey(file, cam, key, "camera_model");
  const std::string camera_model = ReadString(file, model_node, model_key);
  const std::string distortion_key = JoinKey(key, "distortion_model");
  const YAML::Node distortion_node = RequiredKey(file, cam, key, "distortion_model");
  const std::string distortion = ReadString(file, distortion_node, distortion_key);
  const std::string intrinsics_key = JoinKey(key, "intrinsics");
  const YAML::Node intrinsics_node = RequiredKey(file, cam, key, "intrinsics");
  const std::string coeffs_key = JoinKey(key, "distortion_coeffs");
  // Never assign one YAML::Node to another: yaml-cpp then rewrites the node it refers to.
  const YAML::Node coeffs_node =
      distortion != "none" ? RequiredKey(file, cam, key, "distortion_coeffs") : cam;
  std::vector<double> coeffs;
  if (distortion != "none") coeffs = ReadDoubleList(file, coeffs_node, coeffs_key);
  auto expect_coeffs = [&](size_t n, const char* what) {
    if (coeffs.size() != n) {
      ThrowYamlError(file, coeffs_node, coeffs_key,
                     StrCat(distortion, " needs ", n, " numbers (", what, "), got ", coeffs.size()));
    }
  };
  std::vector<double> params;
  if (camera_model == "pinhole") {
    params = ReadDoubleList(file, intrinsics_node, intrinsics_key, 4);  // fu fv cu cv
    if (distortion == "radtan") {
      expect_coeffs(4, "k1 k2 p1 p2");
      camera->model = CameraModelId::kRadTan;
      params.insert(params.end(), coeffs.begin(), coeffs.end());
      params.push_back(0.0);  // k3
    } else if (distortion == "equidistant") {
      expect_coeffs(4, "k1 k2 k3 k4");
      camera->model = CameraModelId::kKannalaBrandt;
      params.insert(params.end(), coeffs.begin(), coeffs.end());
    } else if (distortion == "none") {
      camera->model = CameraModelId::kPinhole;
    } else {
      ThrowYamlError(file, distortion_node, distortion_key,
                     "unsupported distortion model '" + distortion + "' (radtan, equidistant, none)");
    }
  } else if (camera_model == "omni") {  // intrinsics xi fu fv cu cv -> MEI
    const std::vector<double> in = ReadDoubleList(file, intrinsics_node, intrinsics_key, 5);
    if (distortion == "radtan") {
      expect_coeffs(4, "k1 k2 p1 p2");
    } else if (distortion == "none") {
      coeffs.assign(4, 0.0);
    } else {
      ThrowYamlError(file, distortion_node, distortion_key,
                     "unsupported distortion model '" + distortion + "' for omni (radtan, none)");
    }
    camera->model = CameraModelId::kMei;
    params = {in[0], coeffs[0], coeffs[1], coeffs[2], coeffs[3], in[1], in[2], in[3], in[4]};
  } else if (camera_model == "ds") {  // intrinsics xi alpha fu fv cu cv -> double sphere
    const std::vector<double> in = ReadDoubleList(file, intrinsics_node, intrinsics_key, 6);
    if (distortion != "none") {
      ThrowYamlError(file, distortion_node, distortion_key,
                     "the ds camera model takes distortion_model none");
    }
    camera->model = CameraModelId::kDoubleSphere;
    params = {in[2], in[3], in[4], in[5], in[0], in[1]};
  } else {
    ThrowYamlError(file, model_node, model_key,
                   "unsupported camera model '" + camera_model + "' (pinhole, omni, ds)");
  }
  const std::string error = CameraParamsError(camera->model, params);
  if (!error.empty()) ThrowYamlError(file, intrinsics_node, intrinsics_key, error);
  camera->params = std::move(params);
  const Eigen::Vector2i resolution =
      ReadResolution(file, RequiredKey(file, cam, key, "resolution"), JoinKey(key, "resolution"));
  camera->width = resolution.x();
  camera->height = resolution.y();
}

}  // namespace

namespace dataset_internal {

std::vector<Camera> ReadCamchain(const fs::path& path, std::vector<std::string>* log,
                                 std::vector<std::string>* rostopics) {
  const YamlFile file = LoadYamlFile(path);
  std::vector<Camera> cameras;
  CatchYamlErrors(file, [&] {
    size_t count = 0;
    for (const auto& entry : file.root) {
      const std::string key = entry.first.as<std::string>();
      if (key.rfind("cam", 0) == 0) ++count;
    }
    for (size_t k = 0; k < count; ++k) {
      const std::string key = StrCat("cam", k);
      if (!OptionalKey(file.root, key)) {
        ThrowYamlError(
            file, file.root, key,
            StrCat("missing key (", count, " camN entries, expected cam0..cam", count - 1, " without gaps)"));
      }
    }
    if (count == 0) ThrowYamlError(file, file.root, "cam0", "missing key (no camera in the camchain)");

    std::vector<Rigid3d> cam_from_cam0(count);
    std::vector<std::optional<Rigid3d>> cam_from_imu(count);
    for (size_t k = 0; k < count; ++k) {
      const std::string key = StrCat("cam", k);
      const YAML::Node cam = file.root[key];
      if (!cam.IsMap()) ThrowYamlError(file, cam, key, "expected a map of keys");
      Camera camera;
      camera.name = key;
      ReadIntrinsics(file, cam, key, &camera);
      if (k > 0) {
        const std::string chain_key = JoinKey(key, "T_cn_cnm1");
        const YAML::Node chain = RequiredKey(file, cam, key, "T_cn_cnm1");
        const Rigid3d cam_from_previous =
            RigidFromMatrix4(file, chain, chain_key, ReadMatrix4(file, chain, chain_key));
        cam_from_cam0[k] = cam_from_previous * cam_from_cam0[k - 1];
      }
      if (const std::optional<YAML::Node> imu = OptionalKey(cam, "T_cam_imu")) {
        const std::string imu_key = JoinKey(key, "T_cam_imu");
        cam_from_imu[k] = RigidFromMatrix4(file, *imu, imu_key, ReadMatrix4(file, *imu, imu_key));
      }
      if (rostopics != nullptr) {
        const std::optional<YAML::Node> topic = OptionalKey(cam, "rostopic");
        rostopics->push_back(topic ? ReadString(file, *topic, JoinKey(key, "rostopic")) : std::string());
      }
      cameras.push_back(std::move(camera));
    }

    const Rigid3d cam0_from_rig = cam_from_imu[0].value_or(Rigid3d());
    log->push_back(cam_from_imu[0]
                       ? "kalibr: rig frame = IMU (cam0 has T_cam_imu); cameras chained by T_cn_cnm1"
                       : "kalibr: rig frame = cam0; cameras chained by T_cn_cnm1");
    for (size_t k = 0; k < count; ++k) {
      cameras[k].cam_from_rig = cam_from_cam0[k] * cam0_from_rig;
      if (k > 0 && cam_from_imu[0] && cam_from_imu[k]) {
        const Rigid3d diff = cameras[k].cam_from_rig * cam_from_imu[k]->Inverse();
        log->push_back(StrCat("kalibr: ", cameras[k].name, ": chain vs T_cam_imu differ by ",
                              FormatFixed(diff.translation.norm() * 1e3, 3), " mm, ",
                              FormatFixed(Eigen::AngleAxisd(diff.rotation).angle() * 180.0 / M_PI, 4),
                              " deg (the chain is used)"));
      }
    }
  });
  return cameras;
}

}  // namespace dataset_internal

namespace {

bool IsImageFile(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".pgm" || ext == ".bmp";
}

// The images of root/<name>/, named <timestamp_ns>.<ext>, in time order.
CameraImages ListImages(const fs::path& root, const std::string& name) {
  const fs::path folder = root / name;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) MCVO_THROW_INPUT(folder.string(), ": image folder missing");
  std::map<int64_t, fs::path> by_time;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
    const fs::path& path = entry.path();
    if (!entry.is_regular_file(ec) || !IsImageFile(path) || path.filename().string()[0] == '.') continue;
    const std::string stem = path.stem().string();
    const std::optional<int64_t> t_ns =
        std::all_of(stem.begin(), stem.end(), [](unsigned char c) { return std::isdigit(c); })
            ? ParseInt64(stem)
            : std::nullopt;
    if (!t_ns) {
      MCVO_THROW_INPUT(path.string(), ": image file name is not a time stamp (expected <timestamp_ns>",
                       path.extension().string(), ")");
    }
    const auto [it, inserted] = by_time.emplace(*t_ns, path);
    if (!inserted) {
      MCVO_THROW_INPUT(path.string(), ": same time stamp as ", it->second.filename().string());
    }
  }
  if (ec) MCVO_THROW_INPUT(folder.string(), ": cannot list folder: ", ec.message());
  CameraImages images;
  images.name = name;
  for (auto& [t_ns, path] : by_time) {
    images.t_ns.push_back(t_ns);
    images.images.push_back(std::move(path));
  }
  return images;
}

std::string SequenceName(const fs::path& root) {
  fs::path path = root.lexically_normal();
  if (path.filename().empty()) path = path.parent_path();
  return path.filename().string();
}

}  // namespace

DatasetIndex ReadKalibrDataset(const DatasetOptions& options) {
  DatasetIndex index;
  index.format = "kalibr";
  index.name = SequenceName(options.root);
  index.root = options.root;
  const fs::path camchain = FindCamchain(options.root);
  index.log.push_back("kalibr: calibration " + camchain.string());
  const std::vector<Camera> all = dataset_internal::ReadCamchain(camchain, &index.log);

  std::vector<std::string> selected;
  selected.reserve(all.size());
  for (const Camera& camera : all) selected.push_back(camera.name);
  if (!options.cameras.empty()) selected = options.cameras;
  std::vector<CameraImages> streams;
  for (const std::string& name : selected) {
    const auto it = std::find_if(all.begin(), all.end(), [&](const Camera& c) { return c.name == name; });
    if (it == all.end()) {
      throw UsageError(StrCat("cameras: '", EscapeForMessage(name), "' is not a camera of ",
                              camchain.string(), " (cam0..cam", all.size() - 1, ")"));
    }
    index.rig.cameras.push_back(*it);
    streams.push_back(ListImages(options.root, name));
  }
  ValidateRigCameraNames(index.rig, EscapeForMessage(camchain.string()),
                         [&](size_t i) { return index.rig.cameras[i].name; });
  if (streams[0].t_ns.empty()) MCVO_THROW_INPUT((options.root / selected[0]).string(), ": no images");

  dataset_internal::SyncResult sync =
      dataset_internal::SynchronizeCameras(streams, options.sync_tolerance_s, options.missing_images);
  index.log.insert(index.log.end(), sync.log.begin(), sync.log.end());
  index.frames = std::move(sync.frames);
  if (index.frames.empty()) {
    MCVO_THROW_INPUT(options.root.string(), ": no frame has an image from every camera within ",
                     options.sync_tolerance_s, " s");
  }
  index.masks.assign(index.rig.cameras.size(), cv::Mat());

  std::error_code ec;
  for (const auto& [file_name, format] :
       {std::pair<const char*, TrajectoryFormat>{"groundtruth.tum", TrajectoryFormat::kTum},
        {"groundtruth.csv", TrajectoryFormat::kEuroc}}) {
    const fs::path gt = options.root / file_name;
    if (!fs::is_regular_file(gt, ec)) continue;
    index.ground_truth = ReadTrajectory(gt, format);
    index.log.push_back(StrCat("ground truth: ", gt.string(), " (", index.ground_truth->poses.size(),
                               " poses, world_from_rig)"));
    break;
  }
  if (!index.ground_truth) index.log.push_back("ground truth: none (no groundtruth.tum or groundtruth.csv)");
  for (const std::string& line : index.log) MCVO_LOG(kDebug, line);
  return index;
}

}  // namespace mcvo
