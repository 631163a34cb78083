#include "regress_compare.h"

#include <fnmatch.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <locale>
#include <optional>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "mcvo/io/json_util.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo::pipeline_internal {
namespace {

namespace fs = std::filesystem;
using io_internal::JoinPath;
using io_internal::Json;
using io_internal::JsonReader;

constexpr double kRadToDeg = 180.0 / M_PI;

// Always ignored in JSON: not deterministic, or paths and versions rather
// than results.
const char* const kIgnoredJson[] = {
    "run.json:/timing",         "run.json:/version",       "run.json:/build",
    "run.json:/command_line",   "run.json:/config_source", "run.json:/dataset/root",
    "run.json:/outputs_sha256", "*eval.json:/gt/name",     "*eval.json:/est/name"};

}  // namespace

bool Glob(const std::string& pattern, const std::string& text) {
  return ::fnmatch(pattern.c_str(), text.c_str(), 0) == 0;
}

// Short text of a difference or tolerance: 3 significant digits, locale independent.
std::string Short(double value) {
  std::ostringstream out;
  out.imbue(std::locale::classic());
  out << std::setprecision(3) << value;
  return out.str();
}

namespace {

// Bytes of the printable UTF-8 character at text[i] (a multi-byte one only
// when well formed and not a C1 control), 0 when text[i] must be escaped.
size_t PrintableBytes(std::string_view text, size_t i) {
  const unsigned char c = static_cast<unsigned char>(text[i]);
  if (c >= 0x20 && c < 0x7f) return 1;
  const size_t n = c >= 0xc2 && c <= 0xdf ? 2 : c >= 0xe0 && c <= 0xef ? 3 : c >= 0xf0 && c <= 0xf4 ? 4 : 0;
  if (n == 0 || i + n > text.size()) return 0;
  for (size_t k = 1; k < n; ++k) {
    if ((static_cast<unsigned char>(text[i + k]) & 0xc0) != 0x80) return 0;
  }
  if (c == 0xc2 && static_cast<unsigned char>(text[i + 1]) < 0xa0) return 0;  // U+0080..U+009F
  return n;
}

}  // namespace

std::string Clip(std::string_view text, size_t n) {
  std::string out;
  size_t i = 0;
  while (i < text.size()) {
    const size_t bytes = PrintableBytes(text, i);
    std::string piece;
    if (bytes > 0) {
      piece = std::string(text.substr(i, bytes));
    } else {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02x", static_cast<unsigned char>(text[i]));
      piece = escaped;
    }
    if (out.size() + piece.size() > n) break;
    out += piece;
    i += std::max<size_t>(bytes, 1);
  }
  if (i < text.size()) out += StrCat("...[cut: ", text.size() - i, " more bytes]");
  return out;
}

std::vector<std::string_view> Lines(std::string_view text) {
  std::vector<std::string_view> lines;
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(start, end - start);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.push_back(line);
    start = end + 1;
  }
  return lines;
}

std::string FirstDifferingLine(const std::string& a, const std::string& b) {
  const auto la = Lines(a), lb = Lines(b);
  for (size_t i = 0; i < std::max(la.size(), lb.size()); ++i) {
    const std::string_view x = i < la.size() ? la[i] : std::string_view("<end of file>");
    const std::string_view y = i < lb.size() ? lb[i] : std::string_view("<end of file>");
    if (x != y || i >= la.size() || i >= lb.size()) {
      return StrCat("line ", i + 1, ": '", Clip(x), "' vs '", Clip(y), "'");
    }
  }
  return "line endings differ";
}

// The result of comparing one file's contents.

// ---- trajectories ----

std::string DescribePose(const Trajectory& trajectory, size_t i) {
  const StampedPose& pose = trajectory.poses[i];
  if (trajectory.has_time) return StrCat("pose ", i, " (t ", FormatNsAsSeconds(pose.t_ns), " s)");
  return StrCat("pose ", i, " (frame ", pose.frame_index, ")");
}

Outcome CompareTrajectories(const fs::path& a_path, const fs::path& b_path, TrajectoryFormat format,
                            double tolerance_m, double tolerance_deg) {
  Outcome out;
  Trajectory a, b;
  try {
    a = ReadTrajectory(a_path, format);
  } catch (const InputError& e) {
    return {false, true, StrCat("baseline does not read as ", TrajectoryFormatName(format), ": ", e.what())};
  }
  try {
    b = ReadTrajectory(b_path, format);
  } catch (const InputError& e) {
    return {false, true, StrCat("candidate does not read as ", TrajectoryFormatName(format), ": ", e.what())};
  }
  const size_t n = std::min(a.poses.size(), b.poses.size());
  for (size_t i = 0; i < n; ++i) {
    if (a.poses[i].t_ns != b.poses[i].t_ns || a.poses[i].frame_index != b.poses[i].frame_index) {
      auto stamp = [](const Trajectory& t, size_t k) {
        return StrCat(t.has_time ? "t " + FormatNsAsSeconds(t.poses[k].t_ns) + " s" : std::string(),
                      t.has_time && t.has_frame_index ? ", " : "",
                      t.has_frame_index ? StrCat("frame ", t.poses[k].frame_index) : std::string());
      };
      return {false, true,
              StrCat("pose ", i, " is at ", stamp(a, i), " in baseline, ", stamp(b, i),
                     " in candidate: the poses do not correspond")};
    }
  }
  if (a.poses.size() != b.poses.size()) {
    const Trajectory& longer = a.poses.size() > b.poses.size() ? a : b;
    return {false, true,
            StrCat(a.poses.size(), " poses vs ", b.poses.size(), "; first unmatched: ",
                   DescribePose(longer, n), " in ", &longer == &a ? "baseline" : "candidate")};
  }
  double max_m = 0.0, max_deg = 0.0;
  size_t at_m = 0, at_deg = 0;
  std::optional<size_t> first_bad;
  double first_m = 0.0, first_deg = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const Rigid3d& pa = a.poses[i].world_from_body;
    const Rigid3d& pb = b.poses[i].world_from_body;
    const double dm = (pa.translation - pb.translation).norm();
    const Eigen::Quaterniond dq = pa.rotation.conjugate() * pb.rotation;
    const double ddeg = 2.0 * std::atan2(dq.vec().norm(), std::abs(dq.w())) * kRadToDeg;
    if (pa.translation != pb.translation || pa.rotation.coeffs() != pb.rotation.coeffs()) {
      out.values_differ = true;
    }
    if (dm > max_m) max_m = dm, at_m = i;
    if (ddeg > max_deg) max_deg = ddeg, at_deg = i;
    if (!first_bad && (dm > tolerance_m || ddeg > tolerance_deg))
      first_bad = i, first_m = dm, first_deg = ddeg;
  }
  const std::string max_text = StrCat("max ", Short(max_m), " m at ", DescribePose(a, at_m), ", ",
                                      Short(max_deg), " deg at ", DescribePose(a, at_deg));
  if (first_bad) {
    out.within = false;
    out.detail = StrCat(DescribePose(a, *first_bad), ": ", Short(first_m), " m, ", Short(first_deg),
                        " deg apart (tolerance ", Short(tolerance_m), " m, ", Short(tolerance_deg), " deg); ",
                        max_text);
  } else {
    out.detail = StrCat(n, " poses, ", max_text);
  }
  return out;
}

// ---- CSV ----

// Splits a CSV line: fields may be double-quoted, with "" inside for a quote.
std::vector<std::string> SplitCsv(std::string_view line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

// The tolerance of a CSV column or JSON pointer `key` of `file`.
const NumberTolerance& ToleranceFor(const RegressOptions& options, const std::string& file,
                                    const std::string& key) {
  for (const ValueTolerance& v : options.overrides) {
    if (Glob(v.file, file) && Glob(v.key, key)) return v.tolerance;
  }
  return options.numbers;
}

Outcome CompareCsv(const std::string& file, const std::string& a_text, const std::string& b_text,
                   const RegressOptions& options) {
  Outcome out;
  const auto la = Lines(a_text), lb = Lines(b_text);
  if (la.empty() || lb.empty() || la[0] != lb[0]) {
    return {false, true,
            StrCat("header differs: '", Clip(la.empty() ? "" : la[0]), "' vs '",
                   Clip(lb.empty() ? "" : lb[0]), "'")};
  }
  if (la.size() != lb.size()) return {false, true, StrCat(la.size() - 1, " rows vs ", lb.size() - 1)};
  const std::vector<std::string> header = SplitCsv(la[0]);
  double max_diff = 0.0;
  std::string max_where;
  int bad_cells = 0;
  for (size_t row = 1; row < la.size(); ++row) {
    if (la[row] == lb[row]) continue;
    const std::vector<std::string> fa = SplitCsv(la[row]), fb = SplitCsv(lb[row]);
    if (fa.size() != fb.size()) {
      if (out.within) out.detail = StrCat("line ", row + 1, ": ", fa.size(), " fields vs ", fb.size());
      out.within = false;
      out.values_differ = true;
      ++bad_cells;
      continue;
    }
    for (size_t col = 0; col < fa.size(); ++col) {
      if (fa[col] == fb[col]) continue;
      out.values_differ = true;
      const std::string column = col < header.size() ? header[col] : StrCat("#", col + 1);
      const std::string where = StrCat("line ", row + 1, ", column ", column);
      const std::optional<double> x = ParseDouble(Trim(fa[col])), y = ParseDouble(Trim(fb[col]));
      bool ok = false;
      double diff = 0.0;
      if (x && y) {
        ok = ToleranceFor(options, file, column).Accepts(*x, *y);
        diff = std::abs(*x - *y);
        if (std::isfinite(diff) && diff >= max_diff) {
          if (diff > max_diff || max_where.empty()) max_where = where;
          max_diff = diff;
        }
      }
      if (!ok) {
        if (out.within) {
          out.detail = StrCat(where, ": ", Clip(fa[col], 30), " vs ", Clip(fb[col], 30));
          if (x && y) out.detail += StrCat(" (|diff| ", Short(diff), ")");
        }
        out.within = false;
        ++bad_cells;
      }
    }
  }
  const std::string max_text = max_where.empty() ? std::string("no numeric difference")
                                                 : StrCat("max |diff| ", Short(max_diff), " at ", max_where);
  out.detail =
      out.within ? max_text : StrCat(out.detail, "; ", bad_cells, " cell(s) beyond tolerance, ", max_text);
  return out;
}

// ---- JSON ----

struct JsonDiff {
  const std::vector<std::string>* ignores = nullptr;
  const RegressOptions* options = nullptr;  // tolerances (exact: default options)
  std::string file;
  int violations = 0;
  std::string first;
  bool values_differ = false;
  double max_diff = 0.0;
  std::string max_where;
};

bool Ignored(const std::string& pointer, const std::vector<std::string>& ignores) {
  for (const std::string& p : ignores) {
    if (pointer == p ||
        (pointer.size() > p.size() && pointer.compare(0, p.size(), p) == 0 && pointer[p.size()] == '/')) {
      return true;
    }
  }
  return false;
}

void Violation(JsonDiff* d, const std::string& text) {
  if (d->violations++ == 0) d->first = text;
  d->values_differ = true;
}

void CompareJsonValues(const Json& a, const Json& b, const std::string& path, JsonDiff* d) {
  if (Ignored(path, *d->ignores)) return;
  const std::string where = path.empty() ? "/" : path;
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>(), y = b.get<double>();
    if (x == y) return;
    d->values_differ = true;
    const double diff = std::abs(x - y);
    if (diff >= d->max_diff) d->max_diff = diff, d->max_where = where;
    if (!ToleranceFor(*d->options, d->file, where).Accepts(x, y)) {
      Violation(d,
                StrCat(where, ": ", FormatDouble(x), " vs ", FormatDouble(y), " (|diff| ", Short(diff), ")"));
    }
    return;
  }
  if (a.is_object() && b.is_object()) {
    for (const auto& item : a.items()) {
      const std::string p = JoinPath(path, item.key());
      if (!b.contains(item.key())) {
        if (!Ignored(p, *d->ignores)) Violation(d, p + ": missing in candidate");
        continue;
      }
      CompareJsonValues(item.value(), b[item.key()], p, d);
    }
    for (const auto& item : b.items()) {
      const std::string p = JoinPath(path, item.key());
      if (!a.contains(item.key()) && !Ignored(p, *d->ignores)) Violation(d, p + ": missing in baseline");
    }
    return;
  }
  if (a.is_array() && b.is_array()) {
    if (a.size() != b.size()) {
      Violation(d, StrCat(where, ": ", a.size(), " elements vs ", b.size()));
      return;
    }
    for (size_t i = 0; i < a.size(); ++i) CompareJsonValues(a[i], b[i], JoinPath(path, i), d);
    return;
  }
  if (a != b) Violation(d, StrCat(where, ": ", Clip(a.dump(), 40), " vs ", Clip(b.dump(), 40)));
}

std::vector<std::string> JsonIgnoresFor(const std::string& file, const RegressOptions& options) {
  std::vector<std::string> out;
  auto add = [&](const std::string& spec) {
    const size_t colon = spec.find(':');
    if (colon == std::string::npos) {
      out.push_back(spec);
    } else if (Glob(spec.substr(0, colon), file)) {
      out.push_back(spec.substr(colon + 1));
    }
  };
  for (const char* spec : kIgnoredJson) add(spec);
  for (const std::string& spec : options.ignore_json) add(spec);
  return out;
}

Outcome CompareJson(const std::string& file, const std::string& a_text, const std::string& b_text,
                    const RegressOptions& options) {
  Json a, b;
  try {
    a = Json::parse(a_text);
  } catch (const std::exception&) {
    return {false, true, "baseline does not parse as JSON"};
  }
  try {
    b = Json::parse(b_text);
  } catch (const std::exception&) {
    return {false, true, "candidate does not parse as JSON"};
  }
  const std::vector<std::string> ignores = JsonIgnoresFor(file, options);
  const RegressOptions exact;
  JsonDiff d;
  d.ignores = &ignores;
  d.options = options.use_tolerances ? &options : &exact;
  d.file = file;
  CompareJsonValues(a, b, "", &d);
  Outcome out;
  out.values_differ = d.values_differ;
  out.within = d.violations == 0;
  if (!out.within) {
    out.detail = StrCat(d.first, d.violations > 1 ? StrCat(" (and ", d.violations - 1, " more)") : "");
  } else if (d.values_differ) {
    out.detail = StrCat("max |diff| ", Short(d.max_diff), " at ", d.max_where);
  } else {
    out.detail = "differs only in ignored keys or layout";
  }
  return out;
}

// ---- other text ----

// Digits after the decimal point of a number printed in fixed notation
// ("0.0414" -> 4); -1 for integers (counts are not rounded) and exponents.
int Decimals(std::string_view number) {
  const size_t dot = number.find('.');
  if (dot == std::string_view::npos || number.find_first_of("eE") != std::string_view::npos) return -1;
  return static_cast<int>(number.size() - dot - 1);
}

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

// A line cut into text and decimal numbers ("M12.5,-3e-2 L" -> "M", "12.5",
// ",", "-3e-2", " L"), so that numbers inside words, attributes and SVG
// paths are compared as numbers and everything else as text.
struct TextPiece {
  std::string_view text;
  bool number = false;
};

std::vector<TextPiece> CutNumbers(std::string_view line) {
  std::vector<TextPiece> pieces;
  size_t text_start = 0, i = 0;
  const size_t n = line.size();
  while (i < n) {
    size_t j = i;
    if (line[j] == '+' || line[j] == '-') ++j;
    const size_t digits = j;
    while (j < n && IsDigit(line[j])) ++j;
    bool has_digits = j > digits;
    if (j + 1 < n && line[j] == '.' && IsDigit(line[j + 1])) {
      j += 2;
      while (j < n && IsDigit(line[j])) ++j;
      has_digits = true;
    }
    if (!has_digits) {
      ++i;
      continue;
    }
    if (j < n && (line[j] == 'e' || line[j] == 'E')) {
      size_t k = j + 1;
      if (k < n && (line[k] == '+' || line[k] == '-')) ++k;
      const size_t exponent = k;
      while (k < n && IsDigit(line[k])) ++k;
      if (k > exponent) j = k;
    }
    if (i > text_start) pieces.push_back({line.substr(text_start, i - text_start), false});
    pieces.push_back({line.substr(i, j - i), true});
    text_start = i = j;
  }
  if (n > text_start) pieces.push_back({line.substr(text_start), false});
  return pieces;
}

Outcome CompareText(const std::string& a_text, const std::string& b_text, const RegressOptions& options) {
  Outcome out;
  const auto la = Lines(a_text), lb = Lines(b_text);
  if (la.size() != lb.size()) return {false, true, StrCat(la.size(), " lines vs ", lb.size())};
  double max_diff = 0.0;
  std::string max_where;
  for (size_t i = 0; i < la.size(); ++i) {
    if (la[i] == lb[i]) continue;
    out.values_differ = true;
    const std::vector<TextPiece> pa = CutNumbers(la[i]), pb = CutNumbers(lb[i]);
    bool line_ok = pa.size() == pb.size();
    for (size_t k = 0; line_ok && k < pa.size(); ++k) {
      if (pa[k].text == pb[k].text) continue;
      if (!pa[k].number || !pb[k].number) {
        line_ok = false;
        break;
      }
      const std::optional<double> x = ParseDouble(pa[k].text), y = ParseDouble(pb[k].text);
      if (!x || !y) {
        line_ok = false;
        break;
      }
      // Printed numbers are rounded: allow one unit of the last printed digit.
      const int decimals = std::max(Decimals(pa[k].text), Decimals(pb[k].text));
      NumberTolerance tolerance = options.numbers;
      if (decimals >= 0) tolerance.absolute += std::pow(10.0, -decimals) * (1.0 + 1e-9);
      const double diff = std::abs(*x - *y);
      if (diff >= max_diff) max_diff = diff, max_where = StrCat("line ", i + 1);
      line_ok = tolerance.Accepts(*x, *y);
    }
    if (!line_ok) {
      return {false, true, StrCat("line ", i + 1, ": '", Clip(la[i]), "' vs '", Clip(lb[i]), "'")};
    }
  }
  out.detail = StrCat("max |diff| ", Short(max_diff), max_where.empty() ? "" : " at " + max_where);
  return out;
}

}  // namespace mcvo::pipeline_internal
