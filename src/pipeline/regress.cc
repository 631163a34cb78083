#include "mcvo/pipeline/regress.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>
#include <utility>

#include <nlohmann/json.hpp>

#include "mcvo/io/json_util.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/pipeline/run_manifest.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"
#include "regress_compare.h"

namespace mcvo {
namespace {

using namespace pipeline_internal;  // NOLINT: the comparators of regress_compare.h

namespace fs = std::filesystem;
using io_internal::JoinPath;
using io_internal::Json;
using io_internal::JsonReader;

// Always ignored: not deterministic (JSON pointers likewise: regress_compare.cc).
const char* const kIgnoredFiles[] = {"timing.csv"};

// ---- files ----

enum class Kind { kTrajectory, kCsv, kJson, kText };

Kind KindOf(const std::string& file, const fs::path& baseline_file, const fs::path& candidate_file,
            TrajectoryFormat* format) {
  const std::string name = fs::path(file).filename().string();
  const std::string ext = fs::path(file).extension().string();
  if (ext == ".tum") {
    *format = TrajectoryFormat::kTum;
    return Kind::kTrajectory;
  }
  if (ext == ".kitti") {
    *format = TrajectoryFormat::kKitti;
    return Kind::kTrajectory;
  }
  if (ext == ".txt" && name.find("kitti") != std::string::npos) {
    *format = TrajectoryFormat::kKittiIndexed;
    for (const fs::path& path : {baseline_file, candidate_file}) {
      try {
        *format = DetectTrajectoryFormat(path);
        break;
      } catch (const InputError&) {
      }
    }
    return Kind::kTrajectory;
  }
  if (ext == ".csv" && name.find("euroc") != std::string::npos) {
    *format = TrajectoryFormat::kEuroc;
    return Kind::kTrajectory;
  }
  if (ext == ".csv") return Kind::kCsv;
  if (ext == ".json") return Kind::kJson;
  return Kind::kText;
}

// The longest detail a report line prints (Clip: escaped, marked as cut).
constexpr size_t kMaxDetailBytes = 300;

// True when `path`, with its symbolic links resolved, lies inside `root`
// (resolved likewise), not at it.
bool ResolvesInside(const fs::path& root, const fs::path& path) {
  std::error_code ec;
  const fs::path r = fs::weakly_canonical(root, ec);
  if (ec) return false;
  const fs::path p = fs::weakly_canonical(path, ec);
  if (ec) return false;
  auto ri = r.begin(), pi = p.begin();
  for (; ri != r.end(); ++ri, ++pi) {
    if (ri->empty() && std::next(ri) == r.end()) break;  // a trailing separator of root
    if (pi == p.end() || *ri != *pi) return false;
  }
  return pi != p.end();
}

// dir/file, when it resolves inside the run folder `dir`; InputError otherwise:
// regress reads nothing outside the two run folders.
fs::path InsideRunFolder(const fs::path& dir, const std::string& file) {
  const fs::path path = dir / file;
  if (!ResolvesInside(dir, path)) {
    MCVO_THROW_INPUT(dir.string(), ": ", Clip(file, 200),
                     " leads outside the run folder (a symbolic link?); regress reads only files inside"
                     " the run folders");
  }
  return path;
}

// outputs_sha256 names files relative to the run folder: no absolute path,
// no "..", no control characters (the names are printed).
void CheckOutputNames(const RunManifest& run, const fs::path& manifest) {
  for (const auto& [file, hash] : run.outputs_sha256) {
    const std::string pointer = JoinPath("/outputs_sha256", file);
    bool ok = !file.empty() && file.front() != '/' && Clip(file, file.size()) == file;
    for (const fs::path& part : fs::path(file)) ok = ok && part != "..";
    if (!ok) {
      MCVO_THROW_INPUT(manifest.string(), ": ", Clip(pointer, 200),
                       ": not a relative path inside the run folder (absolute paths, \"..\" and control"
                       " characters are not allowed)");
    }
  }
}

FileComparison CompareFileContents(const std::string& file, const fs::path& baseline,
                                   const fs::path& candidate, const RegressOptions& options) {
  FileComparison result;
  result.file = file;
  const fs::path a_path = InsideRunFolder(baseline, file), b_path = InsideRunFolder(candidate, file);
  std::error_code ec;
  const bool has_a = fs::is_regular_file(a_path, ec), has_b = fs::is_regular_file(b_path, ec);
  if (!has_a || !has_b) {
    result.verdict = !has_a ? FileVerdict::kMissingInBaseline : FileVerdict::kMissingInCandidate;
    if (!has_a && !has_b) result.detail = "and in candidate";
    return result;
  }
  const std::string a = ReadFileToString(a_path), b = ReadFileToString(b_path);
  TrajectoryFormat format = TrajectoryFormat::kTum;
  const Kind kind = KindOf(file, a_path, b_path, &format);
  if (a == b) {
    result.verdict = FileVerdict::kIdentical;
    return result;
  }
  Outcome outcome;
  switch (kind) {
    case Kind::kJson:
      outcome = CompareJson(file, a, b, options);
      break;
    case Kind::kTrajectory:
      outcome = options.use_tolerances
                    ? CompareTrajectories(a_path, b_path, format, options.translation_m, options.rotation_deg)
                    : CompareTrajectories(a_path, b_path, format, 0.0, 0.0);
      break;
    case Kind::kCsv:
      outcome = CompareCsv(file, a, b, options.use_tolerances ? options : RegressOptions());
      break;
    case Kind::kText:
      outcome = options.use_tolerances ? CompareText(a, b, options) : Outcome{false, true, ""};
      break;
  }
  if (kind == Kind::kJson) {
    result.verdict = !outcome.within         ? FileVerdict::kDifferent
                     : outcome.values_differ ? FileVerdict::kWithinTolerance
                                             : FileVerdict::kEquivalent;
    result.detail = outcome.detail;
    return result;
  }
  if (!options.use_tolerances) {
    // Exact: any byte counts. Say where, and by how much when the kind tells.
    result.verdict = FileVerdict::kDifferent;
    result.detail = outcome.detail.empty() || !outcome.values_differ
                        ? FirstDifferingLine(a, b) + (outcome.values_differ ? "" : " (the values are equal)")
                        : outcome.detail;
    return result;
  }
  result.verdict = outcome.within ? FileVerdict::kWithinTolerance : FileVerdict::kDifferent;
  result.detail = outcome.detail;
  return result;
}

FileComparison CompareFile(const std::string& file, const fs::path& baseline, const fs::path& candidate,
                           const RegressOptions& options) {
  FileComparison result = CompareFileContents(file, baseline, candidate, options);
  result.detail = Clip(result.detail, kMaxDetailBytes);
  return result;
}

RunManifest ReadRunFolderManifest(const fs::path& dir, const std::string& role) {
  const fs::path path = dir / "run.json";
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) MCVO_THROW_INPUT(dir.string(), ": ", role, " folder does not exist");
  if (!fs::is_regular_file(path, ec)) {
    MCVO_THROW_INPUT(dir.string(), ": ", role, " is not a run folder (no run.json)");
  }
  RunManifest run = RunManifest::Read(InsideRunFolder(dir, "run.json"));
  if (!run.Has("outputs_sha256")) {
    MCVO_THROW_INPUT(path.string(), ": /outputs_sha256: missing (not a run.json of mcvo run)");
  }
  CheckOutputNames(run, path);
  return run;
}

NumberTolerance ReadNumberTolerance(const JsonReader& reader, const Json& value, const std::string& path,
                                    NumberTolerance tolerance,
                                    const std::vector<std::string>& extra_keys = {}) {
  std::vector<std::string> keys = {"absolute", "relative"};
  keys.insert(keys.end(), extra_keys.begin(), extra_keys.end());
  reader.CheckKeys(value, path, keys, {});
  for (const char* key : {"absolute", "relative"}) {
    if (!value.contains(key)) continue;
    const double x = reader.Number(value[key], JoinPath(path, key));
    if (x < 0) reader.Fail(JoinPath(path, key), "must be >= 0");
    (std::string(key) == "absolute" ? tolerance.absolute : tolerance.relative) = x;
  }
  return tolerance;
}

}  // namespace

bool NumberTolerance::Accepts(double a, double b) const {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  if (a == b) return true;  // equal infinities
  return std::abs(a - b) <= absolute + relative * std::max(std::abs(a), std::abs(b));
}

void ParseRegressTolerances(const std::string& json_text, const std::string& source,
                            RegressOptions* options) {
  const JsonReader reader(source);
  const Json root = io_internal::ParseJson(json_text, source);
  reader.CheckKeys(root, "", {"trajectory", "numbers", "overrides", "ignore_files", "ignore_json"}, {});
  options->use_tolerances = true;
  if (root.contains("trajectory")) {
    const Json& t = root["trajectory"];
    reader.CheckKeys(t, "/trajectory", {"translation_m", "rotation_deg"}, {});
    for (const char* key : {"translation_m", "rotation_deg"}) {
      if (!t.contains(key)) continue;
      const double x = reader.Number(t[key], JoinPath("/trajectory", key));
      if (x < 0) reader.Fail(JoinPath("/trajectory", key), "must be >= 0");
      (std::string(key) == "translation_m" ? options->translation_m : options->rotation_deg) = x;
    }
  }
  if (root.contains("numbers")) {
    options->numbers = ReadNumberTolerance(reader, root["numbers"], "/numbers", options->numbers);
  }
  if (root.contains("overrides")) {
    reader.ExpectArray(root["overrides"], "/overrides");
    for (size_t i = 0; i < root["overrides"].size(); ++i) {
      const Json& v = root["overrides"][i];
      const std::string path = JoinPath("/overrides", i);
      reader.CheckKeys(v, path, {"file", "key", "absolute", "relative"}, {"key"});
      ValueTolerance value;
      if (v.contains("file")) value.file = reader.String(v["file"], JoinPath(path, "file"));
      value.key = reader.String(v["key"], JoinPath(path, "key"));
      if (value.key.empty()) reader.Fail(JoinPath(path, "key"), "must not be empty");
      value.tolerance = ReadNumberTolerance(reader, v, path, NumberTolerance(), {"file", "key"});
      options->overrides.push_back(value);
    }
  }
  for (const char* key : {"ignore_files", "ignore_json"}) {
    if (!root.contains(key)) continue;
    const std::string path = JoinPath("", key);
    reader.ExpectArray(root[key], path);
    for (size_t i = 0; i < root[key].size(); ++i) {
      const std::string value = reader.String(root[key][i], JoinPath(path, i));
      if (value.empty()) reader.Fail(JoinPath(path, i), "must not be empty");
      if (std::string(key) == "ignore_json") {
        const size_t colon = value.find(':');
        const std::string pointer = colon == std::string::npos ? value : value.substr(colon + 1);
        if (pointer.empty() || pointer[0] != '/') {
          reader.Fail(JoinPath(path, i),
                      "expected \"/pointer\" or \"FILEGLOB:/pointer\", got \"" + value + "\"");
        }
        options->ignore_json.push_back(value);
      } else {
        options->ignore_files.push_back(value);
      }
    }
  }
}

void ReadRegressTolerances(const fs::path& path, RegressOptions* options) {
  ParseRegressTolerances(ReadFileToString(path), path.string(), options);
}

bool RegressReport::Equal() const {
  for (const FileComparison& f : files) {
    if (f.verdict == FileVerdict::kDifferent || f.verdict == FileVerdict::kMissingInBaseline ||
        f.verdict == FileVerdict::kMissingInCandidate) {
      return false;
    }
  }
  return true;
}

int RegressReport::Count(FileVerdict verdict) const {
  return static_cast<int>(std::count_if(files.begin(), files.end(),
                                        [&](const FileComparison& f) { return f.verdict == verdict; }));
}

const char* FileVerdictName(FileVerdict verdict) {
  switch (verdict) {
    case FileVerdict::kIdentical:
      return "identical";
    case FileVerdict::kEquivalent:
      return "equivalent";
    case FileVerdict::kWithinTolerance:
      return "within tolerance";
    case FileVerdict::kDifferent:
      return "DIFFERENT";
    case FileVerdict::kMissingInBaseline:
      return "MISSING in baseline";
    case FileVerdict::kMissingInCandidate:
      return "MISSING in candidate";
  }
  return "";
}

RegressReport CompareRunFolders(const fs::path& baseline, const fs::path& candidate,
                                const RegressOptions& options) {
  const RunManifest run_a = ReadRunFolderManifest(baseline, "baseline");
  const RunManifest run_b = ReadRunFolderManifest(candidate, "candidate");
  std::set<std::string> files;
  for (const RunManifest* run : {&run_a, &run_b}) {
    for (const auto& [file, hash] : run->outputs_sha256) files.insert(file);
  }
  auto ignored = [&](const std::string& file) {
    for (const char* pattern : kIgnoredFiles) {
      if (Glob(pattern, file)) return true;
    }
    for (const std::string& pattern : options.ignore_files) {
      if (Glob(pattern, file)) return true;
    }
    return false;
  };
  RegressReport report;
  report.baseline = baseline;
  report.candidate = candidate;
  report.files.push_back(CompareFile("run.json", baseline, candidate, options));
  for (const std::string& file : files) {
    if (file == "run.json" || ignored(file)) continue;
    report.files.push_back(CompareFile(file, baseline, candidate, options));
  }
  return report;
}

std::string FormatRegressReport(const RegressReport& report, const RegressOptions& options) {
  std::string text = StrCat("mcvo regress: baseline ", report.baseline.string(), " vs candidate ",
                            report.candidate.string(), "\n");
  if (options.use_tolerances) {
    text += StrCat("tolerances: poses ", Short(options.translation_m), " m, ", Short(options.rotation_deg),
                   " deg; numbers absolute ", Short(options.numbers.absolute), ", relative ",
                   Short(options.numbers.relative),
                   options.overrides.empty() ? "" : StrCat(" (", options.overrides.size(), " override(s))"),
                   "\n");
  } else {
    text += "exact: every file byte for byte (JSON: value for value, ignoring timing, versions and paths)\n";
  }
  size_t width = 0;
  for (const FileComparison& f : report.files) width = std::max(width, f.file.size());
  for (const FileComparison& f : report.files) {
    std::string line =
        "  " + f.file + std::string(width + 2 - f.file.size(), ' ') + FileVerdictName(f.verdict);
    if (!f.detail.empty()) {
      line += (f.verdict == FileVerdict::kDifferent ? ": " : " (") + f.detail +
              (f.verdict == FileVerdict::kDifferent ? "" : ")");
    }
    text += line + "\n";
  }
  const int different = report.Count(FileVerdict::kDifferent) +
                        report.Count(FileVerdict::kMissingInBaseline) +
                        report.Count(FileVerdict::kMissingInCandidate);
  if (different > 0) {
    text += StrCat("result: DIFFERENT (", different, " of ", report.files.size(), " files)\n");
  } else {
    text += StrCat("result: equal (", report.files.size(), " files: ", report.Count(FileVerdict::kIdentical),
                   " identical, ", report.Count(FileVerdict::kEquivalent), " equivalent, ",
                   report.Count(FileVerdict::kWithinTolerance), " within tolerance)\n");
  }
  return text;
}

}  // namespace mcvo
