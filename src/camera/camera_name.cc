// Camera names as path components (include/mcvo/camera/camera.h,
// ValidateCameraName): one check shared by every rig reader.
#include <string>
#include <string_view>

#include "mcvo/camera/camera.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

// The rule `name` breaks, or "".
std::string BrokenRule(std::string_view name) {
  if (name.size() > kMaxCameraNameBytes) {
    return StrCat("is ", name.size(), " bytes long, at most ", kMaxCameraNameBytes, " allowed");
  }
  if (!IsValidUtf8(name)) return "is not valid UTF-8";
  if (name == "." || name == "..") return "must not be \".\" or \"..\"";
  for (const char ch : name) {
    if (ch == '/') return "must not contain '/'";
    if (ch == '\\') return "must not contain '\\'";
  }
  // Control characters: C0 and DEL as bytes, C1 (U+0080..U+009F) as the
  // UTF-8 pairs C2 80..C2 9F.
  for (size_t i = 0; i < name.size(); ++i) {
    const auto byte = static_cast<unsigned char>(name[i]);
    const bool c1 = byte == 0xC2 && i + 1 < name.size() && static_cast<unsigned char>(name[i + 1]) <= 0x9F;
    if (byte < 0x20 || byte == 0x7F || c1) return "must not contain control characters";
  }
  if (name.front() == '.') return "must not start with '.' (a hidden folder)";
  if (name.front() == '-') return "must not start with '-' (it reads as an option)";
  return "";
}

char AsciiLower(char ch) { return ch >= 'A' && ch <= 'Z' ? static_cast<char>(ch - 'A' + 'a') : ch; }

bool EqualIgnoringAsciiCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (AsciiLower(a[i]) != AsciiLower(b[i])) return false;
  }
  return true;
}

}  // namespace

std::string ValidateCameraName(std::string_view name) {
  if (name.empty()) return "camera name must not be empty";
  const std::string rule = BrokenRule(name);
  if (rule.empty()) return "";
  // A name too long to be useful is cut (on a character boundary) in the message.
  constexpr size_t kShown = 120;
  const std::string_view shown = Utf8Prefix(name, kShown);
  return StrCat("\"", EscapeForMessage(shown), shown.size() < name.size() ? "..." : "",
                "\" is not a safe folder name: ", rule);
}

void ValidateRigCameraNames(const Rig& rig, const std::string& source,
                            const std::function<std::string(size_t)>& where) {
  const auto fail = [&](size_t i, const std::string& what) {
    const std::string place = where(i);
    throw InputError(StrCat(source, ": ", place.empty() ? "" : place + ": ", what));
  };
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const std::string& name = rig.cameras[i].name;
    const std::string problem = ValidateCameraName(name);
    if (!problem.empty()) fail(i, problem);
    for (size_t j = 0; j < i; ++j) {
      const std::string& other = rig.cameras[j].name;
      if (name == other) {
        fail(i, StrCat("duplicate camera name \"", EscapeForMessage(name), "\" (also ", where(j), ")"));
      }
      if (EqualIgnoringAsciiCase(name, other)) {
        fail(i, StrCat("camera name \"", EscapeForMessage(name), "\" differs from \"",
                       EscapeForMessage(other), "\" (", where(j),
                       ") only in letter case; names must differ in more than case, "
                       "they name folders"));
      }
    }
  }
}

}  // namespace mcvo
