#include "mcvo/util/strings.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace mcvo {
namespace {

TEST(Strings, ParseDoubleAcceptsWholeNumbersOnly) {
  EXPECT_EQ(ParseDouble("1.5"), 1.5);
  EXPECT_EQ(ParseDouble(" -2e3 "), -2000.0);
  EXPECT_EQ(ParseDouble("+4"), 4.0);
  EXPECT_FALSE(ParseDouble("1.5x").has_value());
  EXPECT_FALSE(ParseDouble("").has_value());
  EXPECT_FALSE(ParseDouble("abc").has_value());
  EXPECT_TRUE(std::isnan(*ParseDouble("nan")));
}

TEST(Strings, FormatDoubleRoundTripsExactly) {
  for (double v : {0.1, 1.0 / 3.0, -1e-300, 6.02214076e23, 552.554261, 1e16 + 2}) {
    EXPECT_EQ(*ParseDouble(FormatDouble(v)), v) << FormatDouble(v);
  }
  EXPECT_EQ(FormatDouble(-0.0), "0");
  EXPECT_EQ(FormatFixed(-0.0001, 3), "0.000");
  EXPECT_EQ(FormatFixed(2.5, 2), "2.50");
}

TEST(Strings, SecondsToNanosecondsIsExactThroughDigits) {
  EXPECT_EQ(ParseSecondsToNs("1369.123456789"), 1369123456789LL);
  EXPECT_EQ(ParseSecondsToNs("1403636579.763555584"), 1403636579763555584LL);
  EXPECT_EQ(ParseSecondsToNs("0.1"), 100000000LL);
  EXPECT_EQ(ParseSecondsToNs("-0.5"), -500000000LL);
  EXPECT_EQ(ParseSecondsToNs("12"), 12000000000LL);
  EXPECT_EQ(ParseSecondsToNs("1.0000000005"), 1000000001LL);  // rounds the 10th digit
  EXPECT_EQ(ParseSecondsToNs("1.5e2"), 150000000000LL);
  EXPECT_FALSE(ParseSecondsToNs("1.2.3").has_value());
  EXPECT_FALSE(ParseSecondsToNs("x").has_value());
  // The int64 range; beyond it is no time (found by tests/fuzz/trajectory_fuzz.cc).
  EXPECT_EQ(ParseSecondsToNs("9223372036.854775807"), std::numeric_limits<int64_t>::max());
  EXPECT_EQ(ParseSecondsToNs("-9223372036.854775807"), -std::numeric_limits<int64_t>::max());
  EXPECT_FALSE(ParseSecondsToNs("9223372036.854775808").has_value());
  EXPECT_FALSE(ParseSecondsToNs("9223372036.8547758075").has_value());  // rounds up past the end
  EXPECT_FALSE(ParseSecondsToNs("9999999999").has_value());
  EXPECT_EQ(FormatNsAsSeconds(1369123456789LL), "1369.123456789");
  EXPECT_EQ(FormatNsAsSeconds(-500000000LL), "-0.500000000");
  EXPECT_EQ(*ParseSecondsToNs(FormatNsAsSeconds(1403636579763555584LL)), 1403636579763555584LL);
}

TEST(Strings, SplitFieldsKeepsEmptyFields) {
  const auto fields = SplitFields("a, b,,c ", ',');
  ASSERT_EQ(fields.size(), 4u);
  EXPECT_EQ(fields[0], "a");
  EXPECT_EQ(fields[1], "b");
  EXPECT_EQ(fields[2], "");
  EXPECT_EQ(fields[3], "c");
  EXPECT_EQ(SplitTokens("  1 2\t3  ").size(), 3u);
}

TEST(Strings, IsValidUtf8RejectsMalformedSequences) {
  EXPECT_TRUE(IsValidUtf8(""));
  EXPECT_TRUE(IsValidUtf8("cam\xC3\xA9ra \xE6\x9D\xB1 \xF0\x9F\x93\xB7"));  // é, 東, a camera emoji
  EXPECT_FALSE(IsValidUtf8("caf\xC3"));                                     // cut in the middle of é
  EXPECT_FALSE(IsValidUtf8("\xFF"));                                        // never a UTF-8 byte
  EXPECT_FALSE(IsValidUtf8("\xC0\xAF"));                                    // overlong '/'
  EXPECT_FALSE(IsValidUtf8("\xED\xA0\x80"));                                // a UTF-16 surrogate
  EXPECT_FALSE(IsValidUtf8("\xF4\x90\x80\x80"));                            // above U+10FFFF
  EXPECT_FALSE(IsValidUtf8("\x80"));                                        // a lone continuation byte
}

TEST(Strings, Utf8PrefixCutsOnACharacterBoundary) {
  const std::string text = "ab\xC3\xA9\xE6\x9D\xB1";  // a b é 東: 1 + 1 + 2 + 3 bytes
  EXPECT_EQ(Utf8Prefix(text, 100), text);
  EXPECT_EQ(Utf8Prefix(text, 7), text);
  EXPECT_EQ(Utf8Prefix(text, 6), "ab\xC3\xA9");  // not into 東
  EXPECT_EQ(Utf8Prefix(text, 5), "ab\xC3\xA9");
  EXPECT_EQ(Utf8Prefix(text, 4), "ab\xC3\xA9");
  EXPECT_EQ(Utf8Prefix(text, 3), "ab");  // not into é
  EXPECT_EQ(Utf8Prefix(text, 0), "");
  for (size_t n = 0; n <= text.size(); ++n) EXPECT_TRUE(IsValidUtf8(Utf8Prefix(text, n))) << n;
}

TEST(Strings, EscapeForMessageKeepsOneLineOfValidUtf8) {
  EXPECT_EQ(EscapeForMessage("cam_0"), "cam_0");
  EXPECT_EQ(EscapeForMessage("a\nb\rc\td"), "a\\nb\\rc\\td");
  EXPECT_EQ(EscapeForMessage("say \"hi\" \\o/"), "say \\\"hi\\\" \\\\o/");
  EXPECT_EQ(EscapeForMessage(std::string("nul\0esc\x1B[31mdel\x7F", 16)), "nul\\x00esc\\x1B[31mdel\\x7F");
  EXPECT_EQ(EscapeForMessage("c1\xC2\x85 ls\xE2\x80\xA8"), "c1\\u{0085} ls\\u{2028}");
  EXPECT_EQ(EscapeForMessage("bad\xFF\xC3"), "bad\\xFF\\xC3");
  EXPECT_EQ(EscapeForMessage("cam\xC3\xA9ra \xE6\x9D\xB1"), "cam\xC3\xA9ra \xE6\x9D\xB1");  // letters stay
  for (const std::string& text : std::vector<std::string>{"x\ny", "\xFF\xFE", "a\x85"}) {
    const std::string escaped = EscapeForMessage(text);
    EXPECT_TRUE(IsValidUtf8(escaped)) << escaped;
    EXPECT_EQ(escaped.find_first_of("\n\r"), std::string::npos) << escaped;
  }
}

}  // namespace
}  // namespace mcvo
