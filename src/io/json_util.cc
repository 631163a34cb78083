#include "mcvo/io/json_util.h"

#include <cmath>
#include <limits>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo::io_internal {
namespace {

// A parser message as one line of valid UTF-8 (its "last read" token may
// hold the very bytes that are not UTF-8).
std::string OneLine(std::string text) {
  if (!IsValidUtf8(text)) text = EscapeForMessage(text);
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return text;
}

// SAX handler that builds the DOM while tracking the JSON path, so that
// duplicate keys and overflowing numbers can be reported where they are.
class PathTrackingBuilder : public nlohmann::json_sax<Json> {
 public:
  explicit PathTrackingBuilder(std::string source) : source_(std::move(source)) {}

  Json& root() { return root_; }
  const std::string& error() const { return error_; }

  bool null() override { return Add(Json(nullptr)); }
  bool boolean(bool value) override { return Add(Json(value)); }
  bool number_integer(number_integer_t value) override { return Add(Json(value)); }
  bool number_unsigned(number_unsigned_t value) override { return Add(Json(value)); }
  bool number_float(number_float_t value, const string_t& /*text*/) override { return Add(Json(value)); }
  bool string(string_t& value) override { return Add(Json(value)); }
  bool binary(binary_t& value) override { return Add(Json::binary(value)); }
  bool start_object(std::size_t /*elements*/) override { return Open(Json::object()); }
  bool start_array(std::size_t /*elements*/) override { return Open(Json::array()); }
  bool end_object() override { return Close(); }
  bool end_array() override { return Close(); }
  bool key(string_t& key) override {
    if (stack_.back()->contains(key)) {
      error_ = StrCat(EscapeForMessage(source_), ": ", EscapeForMessage(JoinPath(ContainerPath(), key)),
                      ": duplicate key");
      return false;
    }
    pending_key_ = key;
    return true;
  }
  bool parse_error(std::size_t /*position*/, const std::string& last_token,
                   const nlohmann::detail::exception& ex) override {
    if (ex.id == 406) {  // number overflow: the value would not be finite
      error_ = StrCat(EscapeForMessage(source_), ": ", EscapeForMessage(PendingPath()), ": number ",
                      last_token, " is out of range (not finite)");
    } else {
      std::string what = ex.what();
      if (const size_t end = what.find("] "); end != std::string::npos) what.erase(0, end + 2);
      error_ = StrCat(EscapeForMessage(source_), ": JSON ", OneLine(what));
    }
    return false;
  }

 private:
  std::string ContainerPath() const {
    std::string path;
    for (const std::string& part : parts_) path += part;
    return path;
  }
  // Path of the value about to be added.
  std::string PendingPath() const {
    if (stack_.empty()) return "/";
    return stack_.back()->is_array() ? JoinPath(ContainerPath(), stack_.back()->size())
                                     : JoinPath(ContainerPath(), pending_key_);
  }
  Json* Insert(Json value) {
    if (stack_.empty()) {
      root_ = std::move(value);
      return &root_;
    }
    Json& container = *stack_.back();
    if (container.is_array()) {
      container.push_back(std::move(value));
      return &container.back();
    }
    Json& slot = container[pending_key_];
    slot = std::move(value);
    return &slot;
  }
  bool Add(Json value) {
    Insert(std::move(value));
    return true;
  }
  bool Open(Json container) {
    const std::string pending = PendingPath();
    const std::string part = stack_.empty() ? "" : pending.substr(ContainerPath().size());
    stack_.push_back(Insert(std::move(container)));
    parts_.push_back(part);
    return true;
  }
  bool Close() {
    stack_.pop_back();
    parts_.pop_back();
    return true;
  }

  std::string source_;
  Json root_;
  std::vector<Json*> stack_;        // open containers, outermost first
  std::vector<std::string> parts_;  // "/key" or "/index" leading into each open container
  std::string pending_key_;
  std::string error_;
};

std::string ListNames(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& name : names) out += (out.empty() ? "" : ", ") + name;
  return out;
}

}  // namespace

Json ParseJson(const std::string& text, const std::string& source) {
  PathTrackingBuilder builder(source);
  const bool ok = Json::sax_parse(text, &builder, Json::input_format_t::json, /*strict=*/true,
                                  /*ignore_comments=*/true);
  if (!ok) throw InputError(builder.error().empty() ? source + ": JSON parse error" : builder.error());
  return std::move(builder.root());
}

Json ReadJsonFile(const std::filesystem::path& path) {
  return ParseJson(ReadFileToString(path), path.string());
}

std::string JoinPath(const std::string& path, std::string_view key) {
  std::string out = path + "/";
  for (char c : key) {
    if (c == '~') {
      out += "~0";
    } else if (c == '/') {
      out += "~1";
    } else {
      out += c;
    }
  }
  return out;
}

std::string JoinPath(const std::string& path, size_t index) { return path + "/" + std::to_string(index); }

std::string DescribeJson(const Json& value) {
  switch (value.type()) {
    case Json::value_t::null:
      return "null";
    case Json::value_t::boolean:
      return value.get<bool>() ? "true" : "false";
    case Json::value_t::string: {
      // dump() escapes control characters; the cut must not split a UTF-8
      // character of the string (the message would not be UTF-8).
      std::string text = value.dump();
      if (text.size() > 40) text = std::string(Utf8Prefix(text, 37)) + "...";
      return "a string (" + text + ")";
    }
    case Json::value_t::number_integer:
    case Json::value_t::number_unsigned:
    case Json::value_t::number_float:
      return "the number " + value.dump();
    case Json::value_t::object:
      return "an object";
    case Json::value_t::array:
      return "an array";
    default:
      return value.type_name();
  }
}

namespace {

bool IsScalarArray(const nlohmann::ordered_json& value) {
  if (!value.is_array()) return false;
  for (const auto& element : value) {
    if (element.is_array() || element.is_object()) return false;
  }
  return true;
}

void AppendPretty(const nlohmann::ordered_json& value, int indent, std::string* out) {
  const std::string pad(static_cast<size_t>(indent + 2), ' ');
  if (value.is_object() && !value.empty()) {
    *out += "{\n";
    size_t i = 0;
    for (const auto& item : value.items()) {
      *out += pad + nlohmann::ordered_json(item.key()).dump() + ": ";
      AppendPretty(item.value(), indent + 2, out);
      *out += ++i < value.size() ? ",\n" : "\n";
    }
    *out += std::string(static_cast<size_t>(indent), ' ') + "}";
  } else if (value.is_array() && !value.empty() && !IsScalarArray(value)) {
    *out += "[\n";
    for (size_t i = 0; i < value.size(); ++i) {
      *out += pad;
      AppendPretty(value[i], indent + 2, out);
      *out += i + 1 < value.size() ? ",\n" : "\n";
    }
    *out += std::string(static_cast<size_t>(indent), ' ') + "]";
  } else if (value.is_array()) {
    *out += "[";
    for (size_t i = 0; i < value.size(); ++i) *out += (i > 0 ? ", " : "") + value[i].dump();
    *out += "]";
  } else {
    *out += value.dump();
  }
}

}  // namespace

std::string PrettyJson(const nlohmann::ordered_json& value) {
  std::string out;
  AppendPretty(value, 0, &out);
  return out + "\n";
}

void JsonReader::Fail(const std::string& path, const std::string& what) const {
  // The file name and the keys in the pointer come from the user: escaped so
  // that the message stays one line.
  throw InputError(
      StrCat(EscapeForMessage(source_), ": ", path.empty() ? "/" : EscapeForMessage(path), ": ", what));
}

void JsonReader::ExpectObject(const Json& value, const std::string& path) const {
  if (!value.is_object()) Fail(path, "expected an object, got " + DescribeJson(value));
}

void JsonReader::CheckKeys(const Json& object, const std::string& path,
                           const std::vector<std::string>& allowed,
                           const std::vector<std::string>& required) const {
  ExpectObject(object, path);
  for (const auto& item : object.items()) {
    bool known = false;
    for (const std::string& name : allowed) known = known || name == item.key();
    if (!known) Fail(JoinPath(path, item.key()), "unknown key (valid keys: " + ListNames(allowed) + ")");
  }
  for (const std::string& name : required) {
    if (!object.contains(name)) Fail(JoinPath(path, name), "missing required key");
  }
}

double JsonReader::Number(const Json& value, const std::string& path) const {
  if (!value.is_number()) Fail(path, "expected a number, got " + DescribeJson(value));
  const double number = value.get<double>();
  if (!std::isfinite(number)) Fail(path, "expected a finite number, got " + FormatDouble(number));
  return number;
}

int64_t JsonReader::Integer(const Json& value, const std::string& path, int64_t min, int64_t max) const {
  int64_t number = 0;
  if (value.is_number_unsigned()) {
    const uint64_t u = value.get<uint64_t>();
    if (u > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) {
      Fail(path, StrCat("must be <= ", max, ", got ", value.dump()));
    }
    number = static_cast<int64_t>(u);
  } else if (value.is_number_integer()) {
    number = value.get<int64_t>();
  } else {
    Fail(path, "expected an integer, got " + DescribeJson(value));
  }
  if (number < min) Fail(path, StrCat("must be >= ", min, ", got ", number));
  if (number > max) Fail(path, StrCat("must be <= ", max, ", got ", number));
  return number;
}

std::string JsonReader::String(const Json& value, const std::string& path) const {
  if (!value.is_string()) Fail(path, "expected a string, got " + DescribeJson(value));
  return value.get<std::string>();
}

bool JsonReader::Bool(const Json& value, const std::string& path) const {
  if (!value.is_boolean()) Fail(path, "expected true or false, got " + DescribeJson(value));
  return value.get<bool>();
}

void JsonReader::ExpectArray(const Json& value, const std::string& path, int size) const {
  if (!value.is_array()) Fail(path, "expected an array, got " + DescribeJson(value));
  if (size >= 0 && value.size() != static_cast<size_t>(size)) {
    Fail(path, StrCat("expected an array of ", size, " elements, got ", value.size()));
  }
}

std::vector<double> JsonReader::Numbers(const Json& value, const std::string& path, int size) const {
  ExpectArray(value, path, size);
  std::vector<double> numbers;
  numbers.reserve(value.size());
  for (size_t i = 0; i < value.size(); ++i) numbers.push_back(Number(value[i], JoinPath(path, i)));
  return numbers;
}

}  // namespace mcvo::io_internal
