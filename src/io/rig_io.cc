// rig.json reader and writer; schema in docs/rig-json.md.
#include "mcvo/io/rig_io.h"

#include <Eigen/SVD>
#include <cmath>

#include "mcvo/io/json_util.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

using io_internal::JoinPath;
using io_internal::Json;
using io_internal::JsonReader;

constexpr CameraModelId kAllModels[] = {CameraModelId::kPinhole, CameraModelId::kRadTan,
                                        CameraModelId::kKannalaBrandt, CameraModelId::kMei,
                                        CameraModelId::kDoubleSphere};

std::string KnownModelNames() {
  std::string names;
  for (CameraModelId id : kAllModels) names += (names.empty() ? "" : ", ") + std::string(CameraModelName(id));
  return names + "; aliases: opencv, equidistant, fisheye, omni, unified";
}

std::string JoinWords(const std::vector<std::string>& words) {
  std::string out;
  for (const std::string& word : words) out += (out.empty() ? "" : " ") + word;
  return out;
}

Eigen::Quaterniond ReadRotationMatrix(const JsonReader& reader, const Json& value, const std::string& path) {
  reader.ExpectArray(value, path, 3);
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) {
    const std::vector<double> row = reader.Numbers(value[r], JoinPath(path, static_cast<size_t>(r)), 3);
    for (int c = 0; c < 3; ++c) m(r, c) = row[static_cast<size_t>(c)];
  }
  const double error = (m.transpose() * m - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (error > kRigRotationTolerance) {
    reader.Fail(path, StrCat("not orthonormal (max |R^T R - I| = ", FormatDouble(error), ", tolerance ",
                             FormatDouble(kRigRotationTolerance), ")"));
  }
  const double det = m.determinant();
  if (det <= 0.0)
    reader.Fail(path, StrCat("determinant is ", FormatDouble(det), " (a reflection), expected +1"));
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return Eigen::Quaterniond(Eigen::Matrix3d(svd.matrixU() * svd.matrixV().transpose())).normalized();
}

Eigen::Quaterniond ReadQuaternion(const JsonReader& reader, const Json& value, const std::string& path) {
  const std::vector<double> wxyz = reader.Numbers(value, path, 4);
  Eigen::Quaterniond q(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > kRigQuaternionTolerance) {
    reader.Fail(path, StrCat("not a unit quaternion (norm ", FormatDouble(norm), ", tolerance ",
                             FormatDouble(kRigQuaternionTolerance), ")"));
  }
  // Keep a quaternion that is unit to rounding as is, so that files written
  // by WriteRig read back bit for bit.
  if (std::abs(q.squaredNorm() - 1.0) > 1e-15) q.normalize();
  return q;
}

Rigid3d ReadTransform(const JsonReader& reader, const Json& value, const std::string& path) {
  reader.CheckKeys(value, path, {"rotation", "quaternion_wxyz", "translation"}, {"translation"});
  const bool has_matrix = value.contains("rotation");
  const bool has_quaternion = value.contains("quaternion_wxyz");
  if (has_matrix == has_quaternion) {
    reader.Fail(path, has_matrix ? "give either \"rotation\" or \"quaternion_wxyz\", not both"
                                 : "missing the rotation: give \"rotation\" (3x3) or \"quaternion_wxyz\"");
  }
  Rigid3d transform;
  transform.rotation =
      has_matrix ? ReadRotationMatrix(reader, value["rotation"], JoinPath(path, "rotation"))
                 : ReadQuaternion(reader, value["quaternion_wxyz"], JoinPath(path, "quaternion_wxyz"));
  const std::vector<double> t = reader.Numbers(value["translation"], JoinPath(path, "translation"), 3);
  transform.translation = Eigen::Vector3d(t[0], t[1], t[2]);
  return transform;
}

// The camera module owns what makes parameters usable (positive focal
// lengths, xi and alpha ranges, ...); the reader adds the file and JSON path.
void CheckParams(const JsonReader& reader, const Camera& camera, const std::string& path) {
  const std::string error = CameraParamsError(camera.model, camera.params);
  if (!error.empty()) reader.Fail(path, error);
}

Camera ReadCamera(const JsonReader& reader, const Json& value, const std::string& path,
                  const std::filesystem::path& base_dir) {
  reader.CheckKeys(value, path,
                   {"name", "model", "width", "height", "params", "cam_from_rig", "rig_from_cam", "mask"},
                   {"name", "model", "width", "height", "params"});
  Camera camera;
  camera.name = reader.String(value["name"], JoinPath(path, "name"));
  // The name becomes a folder name of the outputs: checked before anything
  // else of the camera (ValidateRigCameraNames below repeats it for all).
  if (const std::string problem = ValidateCameraName(camera.name); !problem.empty())
    reader.Fail(JoinPath(path, "name"), problem);

  const std::string model_path = JoinPath(path, "model");
  const std::string model_name = reader.String(value["model"], model_path);
  const std::optional<CameraModelId> model = CameraModelFromName(model_name);
  if (!model) {
    reader.Fail(model_path, "unknown camera model \"" + EscapeForMessage(model_name) +
                                "\" (known: " + KnownModelNames() + ")");
  }
  camera.model = *model;

  camera.width = static_cast<int>(reader.Integer(value["width"], JoinPath(path, "width"), 1, 1 << 20));
  camera.height = static_cast<int>(reader.Integer(value["height"], JoinPath(path, "height"), 1, 1 << 20));

  const std::string params_path = JoinPath(path, "params");
  camera.params = reader.Numbers(value["params"], params_path);
  const std::vector<std::string> names = CameraModelParamNames(camera.model);
  const size_t expected = names.size();
  if (camera.model == CameraModelId::kRadTan && camera.params.size() == expected - 1)
    camera.params.push_back(0.0);
  if (camera.params.size() != expected) {
    reader.Fail(params_path, StrCat("expected ", camera.model == CameraModelId::kRadTan ? "8 or " : "",
                                    expected, " parameters (", JoinWords(names), ") for model ",
                                    CameraModelName(camera.model), ", got ", camera.params.size()));
  }
  CheckParams(reader, camera, params_path);

  const bool has_cam_from_rig = value.contains("cam_from_rig");
  const bool has_rig_from_cam = value.contains("rig_from_cam");
  if (has_cam_from_rig == has_rig_from_cam) {
    reader.Fail(path, has_cam_from_rig ? "give either \"cam_from_rig\" or \"rig_from_cam\", not both"
                                       : "missing the extrinsics: give \"cam_from_rig\" or \"rig_from_cam\"");
  }
  camera.cam_from_rig =
      has_cam_from_rig
          ? ReadTransform(reader, value["cam_from_rig"], JoinPath(path, "cam_from_rig"))
          : ReadTransform(reader, value["rig_from_cam"], JoinPath(path, "rig_from_cam")).Inverse();

  if (value.contains("mask")) {
    const std::string mask_path = JoinPath(path, "mask");
    const std::string mask = reader.String(value["mask"], mask_path);
    if (mask.empty()) reader.Fail(mask_path, "mask path must not be empty (leave the key out for no mask)");
    std::filesystem::path resolved(mask);
    if (resolved.is_relative()) resolved = base_dir / resolved;
    resolved = std::filesystem::absolute(resolved).lexically_normal();
    std::error_code ec;
    if (!std::filesystem::is_regular_file(resolved, ec))
      reader.Fail(mask_path, "mask file not found: " + EscapeForMessage(resolved.string()));
    camera.mask_path = resolved.string();
  }
  return camera;
}

}  // namespace

std::vector<std::string> CameraModelParamNames(CameraModelId model) {
  switch (model) {
    case CameraModelId::kPinhole:
      return {"fx", "fy", "cx", "cy"};
    case CameraModelId::kRadTan:
      return {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
    case CameraModelId::kKannalaBrandt:
      return {"fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"};
    case CameraModelId::kMei:
      return {"xi", "k1", "k2", "p1", "p2", "gamma1", "gamma2", "u0", "v0"};
    case CameraModelId::kDoubleSphere:
      return {"fx", "fy", "cx", "cy", "xi", "alpha"};
  }
  MCVO_CHECK(false);
  return {};
}

Rig ParseRigJson(const std::string& text, const std::string& source, const std::filesystem::path& base_dir) {
  const JsonReader reader(source);
  const Json root = io_internal::ParseJson(text, source);
  reader.CheckKeys(root, "", {"cameras", "description"}, {"cameras"});
  if (root.contains("description")) reader.String(root["description"], "/description");
  const Json& cameras = root["cameras"];
  reader.ExpectArray(cameras, "/cameras");
  if (cameras.empty()) reader.Fail("/cameras", "the rig has no cameras (expected at least one)");
  Rig rig;
  for (size_t i = 0; i < cameras.size(); ++i) {
    rig.cameras.push_back(ReadCamera(reader, cameras[i], JoinPath("/cameras", i), base_dir));
  }
  ValidateRigCameraNames(rig, source, [](size_t i) { return JoinPath(JoinPath("/cameras", i), "name"); });
  return rig;
}

Rig ReadRig(const std::filesystem::path& path) {
  return ParseRigJson(ReadFileToString(path), path.string(), path.parent_path());
}

std::string RigToJson(const Rig& rig, const std::filesystem::path& base_dir) {
  using OJson = nlohmann::ordered_json;
  OJson cameras = OJson::array();
  for (const Camera& camera : rig.cameras) {
    OJson entry;
    entry["name"] = camera.name;
    entry["model"] = std::string(CameraModelName(camera.model));
    entry["width"] = camera.width;
    entry["height"] = camera.height;
    entry["params"] = camera.params;
    const Eigen::Quaterniond& q = camera.cam_from_rig.rotation;
    const Eigen::Vector3d& t = camera.cam_from_rig.translation;
    entry["cam_from_rig"]["quaternion_wxyz"] = {q.w(), q.x(), q.y(), q.z()};
    entry["cam_from_rig"]["translation"] = {t.x(), t.y(), t.z()};
    if (!camera.mask_path.empty()) {
      const std::filesystem::path mask(camera.mask_path);
      const std::filesystem::path base = std::filesystem::absolute(base_dir).lexically_normal();
      const std::filesystem::path relative = mask.lexically_relative(base);
      entry["mask"] = (mask.is_absolute() && !relative.empty() ? relative : mask).generic_string();
    }
    cameras.push_back(std::move(entry));
  }
  OJson root;
  root["cameras"] = std::move(cameras);
  return io_internal::PrettyJson(root);
}

void WriteRig(const std::filesystem::path& path, const Rig& rig) {
  WriteFileAtomic(path, RigToJson(rig, path.parent_path().empty() ? "." : path.parent_path()));
}

}  // namespace mcvo
