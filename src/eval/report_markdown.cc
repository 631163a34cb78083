// report.md: the tables of report.html in Markdown (GitHub flavour). Plots
// cannot be inlined; a line points to report.html.
#include <string>
#include <string_view>

#include "mcvo/eval/report_html.h"
#include "mcvo/util/error.h"
#include "report_common.h"

namespace mcvo {
namespace {

using report_internal::KeyValues;
using report_internal::MdEscape;
using report_internal::Table;

std::string TableMd(const Table& table) {
  std::string out = "|";
  for (const std::string& h : table.header) out += " " + MdEscape(h) + " |";
  out += "\n|";
  for (size_t i = 0; i < table.header.size(); ++i) out += i == 0 ? "---|" : "---:|";
  out += "\n";
  for (const std::vector<std::string>& row : table.rows) {
    out += "|";
    for (const std::string& cell : row) out += " " + MdEscape(cell) + " |";
    out += "\n";
  }
  return out;
}

std::string KeyValueMd(const KeyValues& rows, const char* key_header, const char* value_header) {
  Table table;
  table.header = {key_header, value_header};
  for (const auto& [key, value] : rows) table.rows.push_back({key, value});
  std::string out = TableMd(table);
  // Left-aligned values read better for text.
  const size_t line_end = out.find('\n');
  out.replace(line_end + 1, out.find('\n', line_end + 1) - line_end - 1, "|---|---|");
  return out;
}

}  // namespace

std::string RenderReportMarkdown(const ReportInputs& inputs) {
  std::string out =
      "# " + MdEscape(inputs.title.empty() ? std::string("mcvo report") : inputs.title) + "\n\n";
  out += "mcvo evaluation report. The plots (trajectory, errors along the path, RPE per length";
  if (!inputs.scale_log.empty()) out += ", scale over time";
  out += ") are in report.html next to this file.\n\n";
  if (inputs.eval != nullptr && !inputs.eval->notes.empty()) {
    out += "Notes:\n\n";
    for (const std::string& note : inputs.eval->notes) out += "- " + MdEscape(note) + "\n";
    out += "\n";
  }
  out += "## Summary\n\n" + KeyValueMd(report_internal::SummaryRows(inputs), "quantity", "value") + "\n";
  if (inputs.eval != nullptr) {
    out += "## Error statistics\n\n" + TableMd(report_internal::AteTable(*inputs.eval)) + "\n";
    const Table rpe = report_internal::RpeTable(*inputs.eval);
    if (rpe.rows.empty()) {
      out += "RPE skipped: " + MdEscape(inputs.eval->rpe.skipped_reason) + "\n\n";
    } else {
      out += TableMd(rpe) +
             "\nRPE: means over the segments of each length; rotation per 100 m of nominal length. est/gt "
             "distance: estimated over true travelled distance, estimate unscaled (1 = metric).\n\n";
    }
  } else {
    out += "No ground truth: no errors, RPE or scale error.\n\n";
  }
  if (!inputs.scale_log.empty()) {
    size_t omitted = 0;
    out += "## Scale log\n\n" + TableMd(report_internal::ScaleLogTable(inputs, &omitted));
    if (omitted > 0) out += StrCat("\n", omitted, " more entries (scale\\_log.csv has them all).\n");
    out += "\n";
  }
  out += "## Settings\n\n";
  const KeyValues settings = report_internal::FlattenSettings(inputs.settings);
  if (!settings.empty()) out += KeyValueMd(settings, "key", "value") + "\n";
  if (inputs.eval != nullptr) {
    out += "Evaluation options:\n\n" +
           KeyValueMd(report_internal::EvalOptionRows(*inputs.eval), "key", "value") + "\n";
  }
  if (settings.empty() && inputs.eval == nullptr) out += "None given.\n\n";
  // One trailing newline.
  while (out.size() >= 2 && out[out.size() - 1] == '\n' && out[out.size() - 2] == '\n') out.pop_back();
  return out;
}

}  // namespace mcvo
