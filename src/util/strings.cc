#include "mcvo/util/strings.h"

#include <array>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace mcvo {

std::optional<double> ParseDouble(std::string_view text) {
  text = Trim(text);
  if (text.empty()) return std::nullopt;
  // from_chars does not accept a leading '+'.
  if (text.front() == '+') text.remove_prefix(1);
  double value = 0.0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec == std::errc::result_out_of_range) {
    // Overflow or underflow; keep the IEEE answer (inf or a subnormal/zero).
    std::string copy(text);
    return std::strtod(copy.c_str(), nullptr);
  }
  if (ec != std::errc() || ptr != text.data() + text.size()) return std::nullopt;
  return value;
}

std::optional<int64_t> ParseInt64(std::string_view text) {
  text = Trim(text);
  if (text.empty()) return std::nullopt;
  if (text.front() == '+') text.remove_prefix(1);
  int64_t value = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || ptr != text.data() + text.size()) return std::nullopt;
  return value;
}

std::vector<std::string_view> SplitTokens(std::string_view text, std::string_view delimiters) {
  std::vector<std::string_view> tokens;
  size_t pos = 0;
  while (pos < text.size()) {
    const size_t start = text.find_first_not_of(delimiters, pos);
    if (start == std::string_view::npos) break;
    size_t end = text.find_first_of(delimiters, start);
    if (end == std::string_view::npos) end = text.size();
    tokens.push_back(text.substr(start, end - start));
    pos = end;
  }
  return tokens;
}

std::vector<std::string_view> SplitFields(std::string_view text, char delimiter) {
  std::vector<std::string_view> fields;
  size_t start = 0;
  while (true) {
    const size_t end = text.find(delimiter, start);
    if (end == std::string_view::npos) {
      fields.push_back(Trim(text.substr(start)));
      break;
    }
    fields.push_back(Trim(text.substr(start, end - start)));
    start = end + 1;
  }
  return fields;
}

std::string_view Trim(std::string_view text) {
  constexpr std::string_view kBlanks = " \t\r\n";
  const size_t start = text.find_first_not_of(kBlanks);
  if (start == std::string_view::npos) return {};
  const size_t end = text.find_last_not_of(kBlanks);
  return text.substr(start, end - start + 1);
}

std::string FormatDouble(double value) {
  if (value == 0.0) return "0";  // also maps -0 to "0" for stable outputs
  std::array<char, 64> buffer{};
  const auto [ptr, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  if (ec != std::errc()) return "nan";
  return std::string(buffer.data(), ptr);
}

std::string FormatFixed(double value, int decimals) {
  if (!std::isfinite(value)) return FormatDouble(value);
  std::array<char, 512> buffer{};
  const auto [ptr, ec] =
      std::to_chars(buffer.data(), buffer.data() + buffer.size(), value, std::chars_format::fixed, decimals);
  if (ec != std::errc()) return FormatDouble(value);
  std::string out(buffer.data(), ptr);
  // Print a rounded negative zero ("-0.000") as zero.
  if (out.front() == '-' && out.find_first_not_of("-0.") == std::string::npos) out.erase(0, 1);
  return out;
}

std::optional<int64_t> ParseSecondsToNs(std::string_view text) {
  text = Trim(text);
  if (text.empty()) return std::nullopt;
  if (text.find_first_of("eE") != std::string_view::npos) {
    // Scientific notation: go through long double (64-bit mantissa, enough for
    // nanoseconds over centuries) and round.
    const std::optional<double> check = ParseDouble(text);
    if (!check || !std::isfinite(*check)) return std::nullopt;
    const std::string copy(text);
    const long double seconds = std::strtold(copy.c_str(), nullptr);
    const long double ns = std::round(seconds * 1e9L);
    if (std::fabs(ns) > 9.2e18L) return std::nullopt;
    return static_cast<int64_t>(ns);
  }
  bool negative = false;
  if (text.front() == '-' || text.front() == '+') {
    negative = text.front() == '-';
    text.remove_prefix(1);
  }
  const size_t dot = text.find('.');
  const std::string_view int_part = text.substr(0, dot);
  std::string_view frac_part = dot == std::string_view::npos ? std::string_view() : text.substr(dot + 1);
  if (int_part.empty() && frac_part.empty()) return std::nullopt;
  for (char c : int_part)
    if (c < '0' || c > '9') return std::nullopt;
  for (char c : frac_part)
    if (c < '0' || c > '9') return std::nullopt;
  if (int_part.size() > 10) return std::nullopt;  // > 3e2 years of nanoseconds overflows nothing, but guard
  int64_t seconds = 0;
  for (char c : int_part) seconds = seconds * 10 + (c - '0');
  int64_t frac_ns = 0;
  for (size_t i = 0; i < 9; ++i) frac_ns = frac_ns * 10 + (i < frac_part.size() ? frac_part[i] - '0' : 0);
  // Round half up on the tenth fractional digit.
  if (frac_part.size() > 9 && frac_part[9] >= '5') frac_ns += 1;
  // Ten integer digits can exceed int64 nanoseconds (9223372036.854775807 s):
  // out of range is not a time (found by tests/fuzz/trajectory_fuzz.cc).
  constexpr int64_t kMaxNs = std::numeric_limits<int64_t>::max();
  if (seconds > (kMaxNs - frac_ns) / 1000000000LL) return std::nullopt;
  const int64_t ns = seconds * 1000000000LL + frac_ns;
  return negative ? -ns : ns;
}

std::string FormatNsAsSeconds(int64_t t_ns) {
  const bool negative = t_ns < 0;
  const uint64_t magnitude = negative ? static_cast<uint64_t>(-(t_ns + 1)) + 1 : static_cast<uint64_t>(t_ns);
  const uint64_t seconds = magnitude / 1000000000ULL;
  const uint64_t frac = magnitude % 1000000000ULL;
  std::string frac_text = std::to_string(frac);
  frac_text.insert(0, 9 - frac_text.size(), '0');
  return (negative ? "-" : "") + std::to_string(seconds) + "." + frac_text;
}

std::string CsvQuote(std::string_view text) {
  std::string out = "\"";
  for (char ch : text) {
    if (ch == '"') out += '"';
    out += ch;
  }
  return out + "\"";
}

}  // namespace mcvo
