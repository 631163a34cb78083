// Locale-independent parsing and formatting of numbers for text formats.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mcvo {

// Parses the whole of `text` as a finite or non-finite double ("nan" and
// "inf" are parsed; callers that need finite values check std::isfinite).
// std::nullopt when `text` is not entirely a number.
std::optional<double> ParseDouble(std::string_view text);

// Parses the whole of `text` as a base-10 signed 64-bit integer.
std::optional<int64_t> ParseInt64(std::string_view text);

// Splits on any run of the characters in `delimiters`; no empty tokens.
std::vector<std::string_view> SplitTokens(std::string_view text, std::string_view delimiters = " \t\r");

// Splits on every occurrence of `delimiter` (CSV style: empty fields are
// kept), trimming surrounding blanks from each field.
std::vector<std::string_view> SplitFields(std::string_view text, char delimiter);

// Trims blanks (space, tab, CR, LF) from both ends.
std::string_view Trim(std::string_view text);

// Shortest decimal text that parses back to exactly `value` (round trip),
// independent of the locale. Used by every text writer so outputs are
// byte-identical across runs and loss-free.
std::string FormatDouble(double value);

// Fixed-point text with `decimals` digits, locale independent.
std::string FormatFixed(double value, int decimals);

// Seconds (as written in TUM files) <-> integer nanoseconds. The conversion
// from text goes through the decimal digits, not through a double, so
// "1369.123456789" becomes exactly 1369123456789 ns.
std::optional<int64_t> ParseSecondsToNs(std::string_view text);
std::string FormatNsAsSeconds(int64_t t_ns);

// A CSV field in double quotes, inner quotes doubled (RFC 4180).
std::string CsvQuote(std::string_view text);

}  // namespace mcvo
