#include "mcvo/util/strings.h"

#include <array>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace mcvo {
namespace {

// Length of the well-formed UTF-8 character at text[pos] (1 to 4) and its
// code point, or 0 when the bytes there are not one.
size_t DecodeUtf8(std::string_view text, size_t pos, uint32_t* code_point) {
  const auto byte = [&](size_t i) { return static_cast<unsigned char>(text[pos + i]); };
  const unsigned char lead = byte(0);
  size_t length = 0;
  uint32_t cp = 0;
  uint32_t min = 0;
  if (lead < 0x80) {
    *code_point = lead;
    return 1;
  } else if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2, cp = lead & 0x1Fu, min = 0x80;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3, cp = lead & 0x0Fu, min = 0x800;
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4, cp = lead & 0x07u, min = 0x10000;
  } else {
    return 0;
  }
  if (pos + length > text.size()) return 0;
  for (size_t i = 1; i < length; ++i) {
    if ((byte(i) & 0xC0u) != 0x80u) return 0;
    cp = (cp << 6) | (byte(i) & 0x3Fu);
  }
  if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return 0;
  *code_point = cp;
  return length;
}

std::string Hex(uint32_t value, int digits) {
  static constexpr char kDigits[] = "0123456789ABCDEF";
  std::string out(static_cast<size_t>(digits), '0');
  for (int i = digits - 1; i >= 0; --i, value >>= 4) out[static_cast<size_t>(i)] = kDigits[value & 0xFu];
  return out;
}

}  // namespace

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

bool IsValidUtf8(std::string_view text) {
  uint32_t cp = 0;
  for (size_t pos = 0; pos < text.size();) {
    const size_t length = DecodeUtf8(text, pos, &cp);
    if (length == 0) return false;
    pos += length;
  }
  return true;
}

std::string_view Utf8Prefix(std::string_view text, size_t max_bytes) {
  if (text.size() <= max_bytes) return text;
  size_t end = max_bytes;
  // Step back over continuation bytes to the start of the cut character.
  while (end > 0 && (static_cast<unsigned char>(text[end]) & 0xC0u) == 0x80u) --end;
  return text.substr(0, end);
}

std::string EscapeForMessage(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  uint32_t cp = 0;
  for (size_t pos = 0; pos < text.size();) {
    const size_t length = DecodeUtf8(text, pos, &cp);
    if (length == 0) {
      out += "\\x" + Hex(static_cast<unsigned char>(text[pos]), 2);
      ++pos;
      continue;
    }
    if (cp == '\\' || cp == '"') {
      out += '\\';
      out += static_cast<char>(cp);
    } else if (cp == '\n') {
      out += "\\n";
    } else if (cp == '\r') {
      out += "\\r";
    } else if (cp == '\t') {
      out += "\\t";
    } else if (cp < 0x20 || cp == 0x7F) {
      out += "\\x" + Hex(cp, 2);
    } else if ((cp >= 0x80 && cp <= 0x9F) || cp == 0x2028 || cp == 0x2029) {
      out += "\\u{" + Hex(cp, 4) + "}";
    } else {
      out.append(text.substr(pos, length));
    }
    pos += length;
  }
  return out;
}

}  // namespace mcvo
