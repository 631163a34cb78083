// `mcvo regress`: compares two run folders (what `mcvo run` writes) file by
// file, byte for byte or within tolerances, and says where they differ.
//
//   RegressOptions options;                                   // exact by default
//   ReadRegressTolerances("tolerances.json", &options);      // or set fields
//   const RegressReport report = CompareRunFolders("runs/base", "runs/new", options);
//   std::cout << FormatRegressReport(report, options);
//   return report.Equal() ? 0 : 4;
//
// The files compared: run.json and every file its outputs_sha256 lists, in
// either folder (the union), minus timing.csv and ignore_files. A file
// missing on either side is a difference.
//
// Without tolerances (exact): every file must be byte-identical, except the
// JSON files, which must be equal value for value apart from the ignored keys
// (run.json: timing, version, command_line, config_source, dataset/root,
// outputs_sha256 (the files are compared themselves); eval.json: the
// trajectories' names, which are paths).
//
// With tolerances, files that are not byte-identical are compared by kind:
//   trajectories (*.tum, *.kitti, *kitti*.txt, *euroc*.csv): pose by pose;
//     same poses (time stamps and frame indices exactly), translation
//     |p_b - p_c| <= translation_m and rotation angle(R_b^T R_c) <= rotation_deg
//   *.csv: the same header and rows; numeric cells within the column's
//     tolerance (overrides, else numbers), other cells equal
//   *.json: key by key; numbers within their tolerance (overrides, else
//     numbers), the rest equal
//   other text (*.md, *.html, ...): line by line, cut into text and numbers
//     (also inside words, attributes, SVG paths); the text equal, numbers
//     within `numbers`, plus one unit of the last printed digit for numbers
//     with decimals (they are rounded)
// Docs: docs/batch-and-regress.md.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace mcvo {

// |a - b| <= absolute + relative * max(|a|, |b|); NaN equals NaN.
struct NumberTolerance {
  double absolute = 0.0;
  double relative = 0.0;
  bool Accepts(double a, double b) const;
};

// A tolerance for some values: in files whose relative path matches `file`,
// the CSV columns whose name matches `key`, or the JSON values whose pointer
// (/ate/rotation_deg/rmse) matches `key` (glob patterns: * ? [...]; *
// crosses '/').
struct ValueTolerance {
  std::string file = "*";
  std::string key;
  NumberTolerance tolerance;
};

struct RegressOptions {
  // false: exact comparison (the fields below are not used).
  bool use_tolerances = false;
  double translation_m = 0.0;             // per pose, metres
  double rotation_deg = 0.0;              // per pose, degrees
  NumberTolerance numbers;                // CSV cells, JSON numbers, numbers in text
  std::vector<ValueTolerance> overrides;  // first match wins over `numbers`
  // Relative paths (globs) not compared, besides timing.csv.
  std::vector<std::string> ignore_files;
  // JSON values not compared, besides the defaults above: "FILEGLOB:/pointer"
  // or "/pointer" (any JSON file); a pointer also ignores everything under it.
  std::vector<std::string> ignore_json;
};

// Reads a tolerance file (JSON, docs/batch-and-regress.md) into *options and
// sets use_tolerances. Keys left out keep the values in *options. Errors:
// InputError "<file>: <JSON path>: <what is wrong>".
void ReadRegressTolerances(const std::filesystem::path& path, RegressOptions* options);
void ParseRegressTolerances(const std::string& json_text, const std::string& source, RegressOptions* options);

enum class FileVerdict {
  kIdentical,        // byte for byte
  kEquivalent,       // JSON: equal apart from ignored keys
  kWithinTolerance,  // differs, within the tolerances
  kDifferent,        // differs beyond the tolerances (or at all, when exact)
  kMissingInBaseline,
  kMissingInCandidate,
};

struct FileComparison {
  std::string file;  // relative path, '/'-separated
  FileVerdict verdict = FileVerdict::kIdentical;
  std::string detail;  // one line: largest differences, or the first difference and where
};

struct RegressReport {
  std::filesystem::path baseline, candidate;
  std::vector<FileComparison> files;  // sorted by path, run.json first
  bool Equal() const;                 // no file different or missing
  int Count(FileVerdict verdict) const;
};

// Compares two run folders. Throws InputError when a folder is not a run
// folder (no readable run.json with outputs_sha256).
RegressReport CompareRunFolders(const std::filesystem::path& baseline, const std::filesystem::path& candidate,
                                const RegressOptions& options);

// "identical", "equivalent", "within tolerance", "DIFFERENT", "missing in baseline", ...
const char* FileVerdictName(FileVerdict verdict);

// One line per file ("  <file>  <verdict>[: <detail>]") and a result line.
std::string FormatRegressReport(const RegressReport& report, const RegressOptions& options);

}  // namespace mcvo
