#include "mcvo/util/args.h"

#include <gtest/gtest.h>

#include "mcvo/util/error.h"

namespace mcvo {
namespace {

TEST(ArgParser, ParsesValuesFlagsAndEqualsForm) {
  std::string path;
  int n = 3;
  double x = 0.5;
  bool flag = false;
  ArgParser args("mcvo test", "test");
  args.AddString("path", &path, "FILE", "a path", true);
  args.AddInt("n", &n, "count");
  args.AddDouble("x", &x, "value");
  args.AddFlag("verbose", &flag, "flag");
  const char* argv[] = {"--path", "a.txt", "--n=7", "--verbose"};
  ASSERT_TRUE(args.Parse(4, argv));
  EXPECT_EQ(path, "a.txt");
  EXPECT_EQ(n, 7);
  EXPECT_EQ(x, 0.5);
  EXPECT_TRUE(flag);
  EXPECT_TRUE(args.WasGiven("n"));
  EXPECT_FALSE(args.WasGiven("x"));
}

TEST(ArgParser, RejectsMisuse) {
  auto parse = [](std::vector<const char*> argv) {
    std::string path;
    int n = 0;
    ArgParser args("mcvo test", "test");
    args.AddString("path", &path, "FILE", "a path", true);
    args.AddInt("n", &n, "count");
    return args.Parse(static_cast<int>(argv.size()), argv.data());
  };
  EXPECT_THROW(parse({}), UsageError);                               // missing required
  EXPECT_THROW(parse({"--path"}), UsageError);                       // missing value
  EXPECT_THROW(parse({"--path", "a", "--bogus", "1"}), UsageError);  // unknown option
  EXPECT_THROW(parse({"--path", "a", "--n", "x"}), UsageError);      // not an integer
  EXPECT_THROW(parse({"--path", "a", "stray"}), UsageError);         // positional
  EXPECT_THROW(parse({"--path", "a", "--path", "b"}), UsageError);   // twice
  EXPECT_FALSE(parse({"--help"}));
}

}  // namespace
}  // namespace mcvo
