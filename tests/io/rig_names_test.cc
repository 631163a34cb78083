// Camera names are path components of the outputs: each rule of
// ValidateCameraName, as rig.json reports it (file, JSON pointer, the name
// escaped on one line), and the presets and real rigs that must still load.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "mcvo/camera/camera.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

// JSON text of a camera named `json_name` (the contents of a JSON string).
std::string CameraJson(const std::string& json_name) {
  return R"({"name": ")" + json_name +
         R"(", "model": "pinhole", "width": 10, "height": 10, "params": [5, 5, 5, 5], )"
         R"("cam_from_rig": {"quaternion_wxyz": [1, 0, 0, 0], "translation": [0, 0, 0]}})";
}

std::string RigJson(const std::vector<std::string>& json_names) {
  std::string cameras;
  for (const std::string& name : json_names) cameras += (cameras.empty() ? "" : ", ") + CameraJson(name);
  return R"({"cameras": [)" + cameras + "]}";
}

std::string ErrorOf(const std::vector<std::string>& json_names) {
  try {
    ParseRigJson(RigJson(json_names), "rig.json", ".");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(RigNames, TheIssueExample) {
  EXPECT_EQ(ErrorOf({"a", "b", "../../pwned"}),
            "rig.json: /cameras/2/name: \"../../pwned\" is not a safe folder name: must not contain '/'");
}

TEST(RigNames, EachRuleIsReportedWithTheJsonPointer) {
  const std::string where = "rig.json: /cameras/1/name: ";
  EXPECT_EQ(ErrorOf({"a", ""}), where + "camera name must not be empty");
  EXPECT_EQ(ErrorOf({"a", "."}), where + "\".\" is not a safe folder name: must not be \".\" or \"..\"");
  EXPECT_EQ(ErrorOf({"a", ".."}), where + "\"..\" is not a safe folder name: must not be \".\" or \"..\"");
  EXPECT_EQ(ErrorOf({"a", "left/right"}),
            where + "\"left/right\" is not a safe folder name: must not contain '/'");
  EXPECT_EQ(ErrorOf({"a", "C:\\\\cams"}),
            where + "\"C:\\\\cams\" is not a safe folder name: must not contain '\\'");
  EXPECT_EQ(ErrorOf({"a", "-rf"}),
            where + "\"-rf\" is not a safe folder name: must not start with '-' (it reads as an option)");
  EXPECT_EQ(ErrorOf({"a", ".hidden"}),
            where + "\".hidden\" is not a safe folder name: must not start with '.' (a hidden folder)");
  EXPECT_EQ(ErrorOf({"a", std::string(101, 'x')}),
            where + "\"" + std::string(101, 'x') +
                "\" is not a safe folder name: is 101 bytes long, at most 100 allowed");
}

TEST(RigNames, ControlCharactersAreRejectedAndShownEscapedOnOneLine) {
  const std::string where = "rig.json: /cameras/0/name: ";
  const std::string rule = "\" is not a safe folder name: must not contain control characters";
  EXPECT_EQ(ErrorOf({"cam\\nmcvo run: done"}), where + "\"cam\\nmcvo run: done" + rule);
  EXPECT_EQ(ErrorOf({"tab\\there"}), where + "\"tab\\there" + rule);
  EXPECT_EQ(ErrorOf({"cr\\r"}), where + "\"cr\\r" + rule);
  EXPECT_EQ(ErrorOf({"esc\\u001b[2J"}), where + "\"esc\\x1B[2J" + rule);
  EXPECT_EQ(ErrorOf({"del\\u007f"}), where + "\"del\\x7F" + rule);
  EXPECT_EQ(ErrorOf({"nel\\u0085"}), where + "\"nel\\u{0085}" + rule);  // C1 control
  for (const char* name : {"cam\\nx", "tab\\there", "cr\\r"})
    EXPECT_EQ(ErrorOf({name}).find_first_of("\n\r\t"), std::string::npos) << name;
}

TEST(RigNames, OtherUnicodeLettersAndPunctuationAreFine) {
  for (const std::string& name :
       std::vector<std::string>{"cam\xC3\xA9ra", "\xE5\x89\x8D\xE6\x96\xB9", "\xD0\xBA\xD0\xB0\xD0\xBC",
                                "image_00", "left cam (2)", "a.b", "x-1", "cam+1", std::string(100, 'y')}) {
    EXPECT_EQ(ErrorOf({name}), "(no error)") << name;
    EXPECT_EQ(ValidateCameraName(name), "") << name;
  }
}

TEST(RigNames, InvalidUtf8IsRejected) {
  // JSON text must be UTF-8, so the reader never sees it; a rig built in code
  // (or by another reader) goes through the same check.
  EXPECT_EQ(ValidateCameraName("caf\xC3"), "\"caf\\xC3\" is not a safe folder name: is not valid UTF-8");
  Rig rig;
  rig.cameras.resize(1);
  rig.cameras[0].name = "\xFF";
  try {
    ValidateRigCameraNames(rig, "calib.yaml", [](size_t) { return "cam0"; });
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "calib.yaml: cam0: \"\\xFF\" is not a safe folder name: is not valid UTF-8");
    EXPECT_TRUE(IsValidUtf8(e.what()));
  }
}

TEST(RigNames, ALongNameIsCutOnACharacterBoundaryInTheMessage) {
  // "x", 61 two-byte letters and a '/' (124 bytes): byte 120 is the middle
  // of a letter, so the message shows the first 119 bytes.
  std::string letters;
  for (int i = 0; i < 61; ++i) letters += "\xC3\xA9";
  const std::string message = ValidateCameraName("x" + letters + "/");
  EXPECT_TRUE(IsValidUtf8(message)) << message;
  EXPECT_EQ(message, "\"x" + letters.substr(0, 118) +
                         "...\" is not a safe folder name: is 124 bytes long, at most 100 allowed");
}

TEST(RigNames, NamesMustDifferInMoreThanLetterCase) {
  EXPECT_EQ(ErrorOf({"left", "right", "left"}),
            "rig.json: /cameras/2/name: duplicate camera name \"left\" (also /cameras/0/name)");
  EXPECT_EQ(ErrorOf({"Left", "right", "LEFT"}),
            "rig.json: /cameras/2/name: camera name \"LEFT\" differs from \"Left\" (/cameras/0/name) only in "
            "letter case; names must differ in more than case, they name folders");
  EXPECT_EQ(ErrorOf({"cam_a", "cam_b"}), "(no error)");
}

TEST(RigNames, ThePresetsAndTheRealRigsStillLoad) {
  const fs::path source(MCVO_SOURCE_DIR);
  std::vector<fs::path> rigs;
  for (const fs::path& dir : {source / "config" / "rigs", source / "config" / "rigs" / "suite"}) {
    for (const fs::directory_entry& entry : fs::directory_iterator(dir))
      if (entry.path().extension() == ".json") rigs.push_back(entry.path());
  }
  std::error_code ec;
  const fs::path real = source / ".." / "shared" / "data" / "real";
  if (fs::is_directory(real, ec)) {
    for (const fs::directory_entry& entry : fs::directory_iterator(real))
      if (fs::is_regular_file(entry.path() / "rig.json")) rigs.push_back(entry.path() / "rig.json");
  }
  EXPECT_GE(rigs.size(), 10u);
  for (const fs::path& rig : rigs) EXPECT_NO_THROW(ReadRig(rig)) << rig;
}

}  // namespace
}  // namespace mcvo
