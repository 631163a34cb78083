// Private to src/eval: what report.html and report.md share (report_html.cc,
// report_markdown.cc): the summary lines, the tables and the data series of
// the plots, computed once from ReportInputs so both files say the same.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "mcvo/eval/report_html.h"

namespace mcvo::report_internal {

using KeyValues = std::vector<std::pair<std::string, std::string>>;

// Most scale-log lines listed in a table (the CSV has them all).
inline constexpr size_t kMaxScaleLogRows = 500;

struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

// Text that reads literally in a Markdown paragraph or table cell, also when
// the Markdown is rendered as HTML: line breaks become spaces, & < > become
// entities, \\ | ` [ ] are backslash-escaped (no code span, table cell or
// link), other control characters become U+FFFD. With escape_emphasis, also
// * _ # (report.md; eval.md keeps file names such as est_vo.tum as they are,
// emphasis is not markup that can do harm). report.md and eval.md quote user
// text (file names, settings) only through it.
std::string MdEscape(std::string_view text, bool escape_emphasis = true);

// inputs.estimate, or eval->est_aligned when that is empty and eval is set.
const Trajectory& ReportEstimate(const ReportInputs& inputs);

// "camera <i>" when camera_names has no entry i.
std::string CameraName(const ReportInputs& inputs, size_t camera);
// Cameras the scale log speaks of: max(camera_names, longest camera_scales).
size_t NumScaleCameras(const ReportInputs& inputs);

// The summary (label, value): from eval (or the trajectory alone), the scale
// log's event counts, then inputs.summary_rows.
KeyValues SummaryRows(const ReportInputs& inputs);

// Nested objects become dotted keys ("backend.window_size"), arrays of
// objects "cameras[0].name"; arrays of scalars stay one value ("[1,2]").
// Strings are shown without quotes; other values as JSON. Empty for null.
KeyValues FlattenSettings(const nlohmann::ordered_json& settings);
// The eval options as EvalResultToJson writes them ("options"), flattened.
KeyValues EvalOptionRows(const EvalResult& eval);

Table AteTable(const EvalResult& eval);
// One row per RPE length and one for the average; empty when RPE was skipped.
Table RpeTable(const EvalResult& eval);
// The first kMaxScaleLogRows entries; *omitted gets the rest's count.
Table ScaleLogTable(const ReportInputs& inputs, size_t* omitted);

// Per matched pose, in pair order: distance travelled along the matched
// ground-truth positions (the RPE's distance, docs/eval.md) and the errors.
// Falls back to the aligned estimate's positions when ground_truth does not
// hold the evaluated poses.
struct PathErrorSeries {
  bool along_ground_truth = true;
  std::vector<double> distance_m;
  std::vector<double> translation_m;
  std::vector<double> rotation_deg;
};
PathErrorSeries ErrorsAlongPath(const ReportInputs& inputs);

// Fixed decimals; "-" for a value that does not exist.
std::string Fixed(double value, int decimals);
std::string StatOrDash(const ErrorStats& stats, double value, int decimals);
// "100 m", "118.1 m", "2.25 m": integers without decimals, else 1 (>= 10 m) or 2.
std::string LengthText(double length_m);

}  // namespace mcvo::report_internal
