// Private helpers of the YAML-based dataset readers (EuRoC sensor.yaml,
// Kalibr camchain.yaml). Every problem becomes an InputError whose message
// names the file, the line where yaml-cpp knows it, and the key path:
//
//   "<file>:<line>: <key path>: <what is wrong>"   e.g.
//   "data/camchain.yaml:12: cam1/T_cn_cnm1: rotation not orthonormal (|R^T R - I| = 0.02 > 1e-05)"
//
// No yaml-cpp exception leaves these functions (nor the readers, which wrap
// their YAML access in CatchYamlErrors).
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>
#include <Eigen/Core>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo::dataset_internal {

// A parsed YAML file and the path used in messages.
struct YamlFile {
  std::filesystem::path path;
  YAML::Node root;  // a map (checked)
};

// Reads and parses `path`. A missing file throws "<path>: missing <what>"
// (what: "calibration file"), a syntax error "<path>:<line>: YAML syntax
// error: ...". An OpenCV "%YAML:1.0" first line is accepted (blanked, so
// line numbers are kept). The document must be a map.
YamlFile LoadYamlFile(const std::filesystem::path& path, const std::string& what = "calibration file");
// As LoadYamlFile, from the file's text (`path` names it in errors).
YamlFile ParseYamlText(const std::filesystem::path& path, std::string text);

// Throws InputError "<file>[:<line>]: <key_path>: <what>" (line from the node's mark).
[[noreturn]] void ThrowYamlError(const YamlFile& file, const YAML::Node& node, const std::string& key_path,
                                 const std::string& what);

// Runs `body`; a YAML::Exception escaping it is rethrown as InputError naming the file and line.
void CatchYamlErrors(const YamlFile& file, const std::function<void()>& body);

// "parent/key" (or "key" when parent is empty).
std::string JoinKey(const std::string& parent, const std::string& key);

// map[key]; throws "<file>:<line>: <parent/key>: missing key" when absent or null.
YAML::Node RequiredKey(const YamlFile& file, const YAML::Node& map, const std::string& parent,
                       const std::string& key);
// map[key], or nullopt when absent or null.
std::optional<YAML::Node> OptionalKey(const YAML::Node& map, const std::string& key);

std::string ReadString(const YamlFile& file, const YAML::Node& node, const std::string& key_path);
// A finite number.
double ReadDouble(const YamlFile& file, const YAML::Node& node, const std::string& key_path);
// A flat list of finite numbers; `expected_size` (when given) is enforced.
std::vector<double> ReadDoubleList(const YamlFile& file, const YAML::Node& node, const std::string& key_path,
                                   std::optional<size_t> expected_size = std::nullopt);
// [width, height], both > 0.
Eigen::Vector2i ReadResolution(const YamlFile& file, const YAML::Node& node, const std::string& key_path);

// A 4x4 matrix written as {rows: 4, cols: 4, data: [16 row-major]} (EuRoC,
// OpenCV), as a nested list of 4 rows (Kalibr) or as a flat list of 16.
Eigen::Matrix4d ReadMatrix4(const YamlFile& file, const YAML::Node& node, const std::string& key_path);

// The rigid transform of a homogeneous 4x4 matrix: the last row must be
// 0 0 0 1 and the rotation orthonormal with det +1 (max |R^T R - I| <=
// kRigRotationTolerance); it is projected onto SO(3).
Rigid3d RigidFromMatrix4(const YamlFile& file, const YAML::Node& node, const std::string& key_path,
                         const Eigen::Matrix4d& matrix);

}  // namespace mcvo::dataset_internal
