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

// Whether `text` is well-formed UTF-8 (no overlong forms, surrogates or
// code points above U+10FFFF).
bool IsValidUtf8(std::string_view text);

// The longest prefix of `text` of at most `max_bytes` bytes that does not end
// inside a UTF-8 character, so that cutting user text for a message keeps the
// message valid UTF-8.
std::string_view Utf8Prefix(std::string_view text, size_t max_bytes);

// User text (a camera or file name) made safe to quote inside a one-line
// error message: backslash and double quote are backslash-escaped, newline,
// carriage return and tab become \n, \r and \t, other control characters
// (C0, DEL, C1) and the Unicode line and paragraph separators become
// \xHH or \u{HHHH}, bytes that are not UTF-8 become \xHH. Other UTF-8
// characters are kept as they are. The caller adds the quotes.
std::string EscapeForMessage(std::string_view text);

}  // namespace mcvo
