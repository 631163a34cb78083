// JSON helpers private to the io module (the only module that knows JSON).
// Every error is one line "<source>: <JSON path>: <what is wrong>", the JSON
// path written as an RFC 6901 pointer (/cameras/1/cam_from_rig/rotation).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace mcvo::io_internal {

using Json = nlohmann::json;

// Parses JSON text (comments allowed). Syntax errors name the line and
// column; duplicate keys and numbers that overflow a double name the JSON
// path. `source` (the file name) starts every message.
Json ParseJson(const std::string& text, const std::string& source);
Json ReadJsonFile(const std::filesystem::path& path);

// Appends one reference token to a JSON pointer.
std::string JoinPath(const std::string& path, std::string_view key);
std::string JoinPath(const std::string& path, size_t index);

// "a string (\"abc\")", "the number 1.5", "an object", ... for error messages.
std::string DescribeJson(const Json& value);

// Pretty prints with two-space indentation, keys in insertion order, and
// arrays of scalars on one line (rig rotations read as 3 rows). Numbers use
// the shortest text that parses back exactly. Ends with a newline.
std::string PrettyJson(const nlohmann::ordered_json& value);

// Typed access with errors that name the source and the JSON path.
class JsonReader {
 public:
  explicit JsonReader(std::string source) : source_(std::move(source)) {}
  const std::string& source() const { return source_; }

  [[noreturn]] void Fail(const std::string& path, const std::string& what) const;

  void ExpectObject(const Json& value, const std::string& path) const;
  // Rejects keys not in `allowed` (listing the valid ones) and reports the
  // first missing key of `required`.
  void CheckKeys(const Json& object, const std::string& path, const std::vector<std::string>& allowed,
                 const std::vector<std::string>& required) const;
  // Finite number (integers are accepted).
  double Number(const Json& value, const std::string& path) const;
  // Integer (a number with a fraction is rejected) within [min, max].
  int64_t Integer(const Json& value, const std::string& path, int64_t min, int64_t max) const;
  std::string String(const Json& value, const std::string& path) const;
  bool Bool(const Json& value, const std::string& path) const;
  // An array; when size >= 0 it must have exactly that many elements.
  void ExpectArray(const Json& value, const std::string& path, int size = -1) const;
  std::vector<double> Numbers(const Json& value, const std::string& path, int size = -1) const;

 private:
  std::string source_;
};

}  // namespace mcvo::io_internal
