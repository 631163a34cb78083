// The file comparators of `mcvo regress` (private to pipeline/; regress.h):
// trajectories by pose (translation in m, rotation in deg), CSV and JSON by
// value with per-column / per-pointer tolerances, other text by its numbers.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "mcvo/io/trajectory_io.h"
#include "mcvo/pipeline/regress.h"

namespace mcvo::pipeline_internal {

struct Outcome {
  bool within = true;          // no difference beyond the tolerances
  bool values_differ = false;  // some compared value is not exactly equal
  std::string detail;
};

// fnmatch(3) of a file name or JSON pointer pattern.
bool Glob(const std::string& pattern, const std::string& text);
// A number in few characters.
std::string Short(double value);
// Text of a file, safe to print on one line: at most n bytes of it, bytes
// that are not printable UTF-8 (controls, escapes, broken sequences) as
// \xNN, and when it does not all fit, "...[cut: K more bytes]".
std::string Clip(std::string_view text, size_t n = 60);
// "line N: <a> | <b>" for the first line that differs.
std::string FirstDifferingLine(const std::string& a, const std::string& b);

Outcome CompareTrajectories(const std::filesystem::path& a_path, const std::filesystem::path& b_path,
                            TrajectoryFormat format, double tolerance_m, double tolerance_deg);
Outcome CompareCsv(const std::string& file, const std::string& a_text, const std::string& b_text,
                   const RegressOptions& options);
Outcome CompareJson(const std::string& file, const std::string& a_text, const std::string& b_text,
                    const RegressOptions& options);
Outcome CompareText(const std::string& a_text, const std::string& b_text, const RegressOptions& options);

}  // namespace mcvo::pipeline_internal
