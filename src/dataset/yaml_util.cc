#include "yaml_util.h"

#include <cmath>
#include <sstream>
#include <utility>

#include <Eigen/SVD>

#include "mcvo/io/rig_io.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo::dataset_internal {
namespace {

// 1-based line of a node, 0 when unknown.
int LineOf(const YAML::Node& node) {
  try {
    if (!node.IsDefined()) return 0;
    const YAML::Mark mark = node.Mark();
    return mark.is_null() ? 0 : mark.line + 1;
  } catch (const YAML::Exception&) {
    return 0;
  }
}

std::string Where(const std::filesystem::path& path, int line) {
  return line > 0 ? StrCat(path.string(), ":", line) : path.string();
}

std::string Describe(const YAML::Node& node) {
  if (node.IsScalar()) return StrCat("'", node.Scalar(), "'");
  if (node.IsSequence()) return StrCat("a list of ", node.size());
  if (node.IsMap()) return "a map";
  return "nothing";
}

}  // namespace

YamlFile LoadYamlFile(const std::filesystem::path& path, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) MCVO_THROW_INPUT(path.string(), ": missing ", what);
  return ParseYamlText(path, ReadFileToString(path));
}

YamlFile ParseYamlText(const std::filesystem::path& path, std::string text) {
  // OpenCV FileStorage writes "%YAML:1.0", which is not a YAML 1.x directive.
  if (text.rfind("%YAML:", 0) == 0) text[0] = '#';
  YamlFile file{path, YAML::Node()};
  try {
    file.root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    MCVO_THROW_INPUT(Where(path, e.mark.is_null() ? 0 : e.mark.line + 1), ": YAML syntax error: ", e.msg);
  }
  if (!file.root.IsMap()) MCVO_THROW_INPUT(path.string(), ": expected a YAML map of keys at the top level");
  return file;
}

void ThrowYamlError(const YamlFile& file, const YAML::Node& node, const std::string& key_path,
                    const std::string& what) {
  MCVO_THROW_INPUT(Where(file.path, LineOf(node)), ": ", key_path, ": ", what);
}

void CatchYamlErrors(const YamlFile& file, const std::function<void()>& body) {
  try {
    body();
  } catch (const YAML::Exception& e) {
    MCVO_THROW_INPUT(Where(file.path, e.mark.is_null() ? 0 : e.mark.line + 1), ": ", e.msg);
  }
}

std::string JoinKey(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : StrCat(parent, "/", key);
}

std::optional<YAML::Node> OptionalKey(const YAML::Node& map, const std::string& key) {
  if (!map.IsMap()) return std::nullopt;
  const YAML::Node value = map[key];
  if (!value.IsDefined() || value.IsNull()) return std::nullopt;
  return value;
}

YAML::Node RequiredKey(const YamlFile& file, const YAML::Node& map, const std::string& parent,
                       const std::string& key) {
  if (!map.IsMap())
    ThrowYamlError(file, map, parent.empty() ? "<top level>" : parent, "expected a map of keys");
  std::optional<YAML::Node> value = OptionalKey(map, key);
  if (!value) ThrowYamlError(file, map, JoinKey(parent, key), "missing key");
  return *value;
}

std::string ReadString(const YamlFile& file, const YAML::Node& node, const std::string& key_path) {
  if (!node.IsScalar())
    ThrowYamlError(file, node, key_path, StrCat("expected a string, got ", Describe(node)));
  return node.Scalar();
}

double ReadDouble(const YamlFile& file, const YAML::Node& node, const std::string& key_path) {
  if (!node.IsScalar())
    ThrowYamlError(file, node, key_path, StrCat("expected a number, got ", Describe(node)));
  const std::optional<double> value = ParseDouble(Trim(node.Scalar()));
  if (!value || !std::isfinite(*value)) {
    ThrowYamlError(file, node, key_path, StrCat("expected a finite number, got '", node.Scalar(), "'"));
  }
  return *value;
}

std::vector<double> ReadDoubleList(const YamlFile& file, const YAML::Node& node, const std::string& key_path,
                                   std::optional<size_t> expected_size) {
  if (!node.IsSequence()) {
    ThrowYamlError(file, node, key_path, StrCat("expected a list of numbers, got ", Describe(node)));
  }
  if (expected_size && node.size() != *expected_size) {
    ThrowYamlError(file, node, key_path, StrCat("expected ", *expected_size, " numbers, got ", node.size()));
  }
  std::vector<double> values;
  values.reserve(node.size());
  for (size_t i = 0; i < node.size(); ++i) {
    values.push_back(ReadDouble(file, node[i], StrCat(key_path, "[", i, "]")));
  }
  return values;
}

Eigen::Vector2i ReadResolution(const YamlFile& file, const YAML::Node& node, const std::string& key_path) {
  const std::vector<double> values = ReadDoubleList(file, node, key_path, 2);
  for (const double v : values) {
    if (v < 1 || v > 1e6 || v != std::floor(v)) {
      ThrowYamlError(file, node, key_path, "expected [width, height], positive integers");
    }
  }
  return Eigen::Vector2i(static_cast<int>(values[0]), static_cast<int>(values[1]));
}

Eigen::Matrix4d ReadMatrix4(const YamlFile& file, const YAML::Node& node, const std::string& key_path) {
  std::vector<double> values;
  if (node.IsMap()) {  // {rows, cols, data} (EuRoC, OpenCV)
    for (const char* key : {"rows", "cols"}) {
      const double n = ReadDouble(file, RequiredKey(file, node, key_path, key), JoinKey(key_path, key));
      if (n != 4) ThrowYamlError(file, node, JoinKey(key_path, key), "expected 4");
    }
    values = ReadDoubleList(file, RequiredKey(file, node, key_path, "data"), JoinKey(key_path, "data"), 16);
  } else if (node.IsSequence() && node.size() == 4) {  // nested rows (Kalibr)
    for (size_t r = 0; r < 4; ++r) {
      const std::vector<double> row = ReadDoubleList(file, node[r], StrCat(key_path, "[", r, "]"), 4);
      values.insert(values.end(), row.begin(), row.end());
    }
  } else if (node.IsSequence() && node.size() == 16) {
    values = ReadDoubleList(file, node, key_path, 16);
  } else {
    ThrowYamlError(file, node, key_path,
                   StrCat("expected a 4x4 matrix ({rows, cols, data}, 4 rows of 4, or 16 numbers), got ",
                          Describe(node)));
  }
  Eigen::Matrix4d matrix;
  for (int i = 0; i < 16; ++i) matrix(i / 4, i % 4) = values[static_cast<size_t>(i)];
  return matrix;
}

Rigid3d RigidFromMatrix4(const YamlFile& file, const YAML::Node& node, const std::string& key_path,
                         const Eigen::Matrix4d& matrix) {
  const Eigen::RowVector4d last_row = matrix.row(3);
  if ((last_row - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9) {
    std::ostringstream row;
    row << last_row;
    ThrowYamlError(file, node, key_path, StrCat("last row must be 0 0 0 1, got ", row.str()));
  }
  const Eigen::Matrix3d rotation = matrix.topLeftCorner<3, 3>();
  const double error = (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(error <= kRigRotationTolerance)) {
    ThrowYamlError(
        file, node, key_path,
        StrCat("rotation not orthonormal (max |R^T R - I| = ", error, " > ", kRigRotationTolerance, ")"));
  }
  if (rotation.determinant() < 0) ThrowYamlError(file, node, key_path, "rotation is a reflection (det < 0)");
  // Nearest rotation (polar decomposition) so that composed chains stay in SO(3).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(rotation, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d projected = svd.matrixU() * svd.matrixV().transpose();
  return Rigid3d(projected, Eigen::Vector3d(matrix.topRightCorner<3, 1>()));
}

}  // namespace mcvo::dataset_internal
