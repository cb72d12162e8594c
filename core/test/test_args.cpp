// pplvo::ArgParser: both value forms, flags, typed values with bounds, collected errors,
// unknown options, --help, and the --progress convention.
#include "pplvo/core/args.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <string>
#include <vector>

namespace pplvo {
namespace {

struct Opts {
  std::string url = "default";
  int window = 10;
  int64_t start = 0;
  double rate = 1.0;
  bool compress = false;
  bool loop = false;
  bool progress = true;
  std::string mode = "a";
};

ArgParser makeParser(Opts* o) {
  ArgParser p;
  p.option("--lcm-url", &o->url)
      .option("--window", &o->window, 1, 100)
      .option("--start", &o->start, int64_t{0})
      .option("--rate", &o->rate, 0.0)
      .option("--compress", &o->compress)
      .option("--mode",
              [o](const std::string& v) -> std::string {
                if (v != "a" && v != "b") return "--mode: a or b, not '" + v + "'";
                o->mode = v;
                return "";
              })
      .flag("--loop", &o->loop)
      .flag("--progress", &o->progress)
      .flag("--no-progress", &o->progress, false);
  return p;
}

TEST(ArgParser, BothValueFormsFlagsAndTypes) {
  Opts o;
  ArgParser p = makeParser(&o);
  EXPECT_TRUE(p.parse({"--lcm-url", "memq://", "--window=5", "--start", "7", "--rate=-0",
                       "--compress", "on", "--mode=b", "--loop", "--no-progress"}));
  EXPECT_TRUE(p.errors().empty());
  EXPECT_FALSE(p.help());
  EXPECT_EQ(o.url, "memq://");
  EXPECT_EQ(o.window, 5);
  EXPECT_EQ(o.start, 7);
  EXPECT_EQ(o.rate, 0.0);
  EXPECT_TRUE(o.compress);
  EXPECT_EQ(o.mode, "b");
  EXPECT_TRUE(o.loop);
  EXPECT_FALSE(o.progress);
  EXPECT_TRUE(p.given("--window"));
  EXPECT_TRUE(p.given("--no-progress"));
  EXPECT_FALSE(p.given("--progress"));
}

TEST(ArgParser, ValueIsTakenVerbatimAndEqualsSplitsOnce) {
  Opts o;
  ArgParser p = makeParser(&o);
  // "--lcm-url --loop": the next argument is the value even if it looks like an option.
  EXPECT_TRUE(p.parse({"--lcm-url", "--loop", "--mode", "a", "--lcm-url=udpm://x?ttl=0"}));
  EXPECT_EQ(o.url, "udpm://x?ttl=0");  // later occurrence wins; only the first '=' splits
  EXPECT_FALSE(o.loop);
  Opts o2;
  ArgParser q = makeParser(&o2);
  EXPECT_TRUE(q.parse({"--lcm-url="}));  // explicit empty value
  EXPECT_EQ(o2.url, "");
}

TEST(ArgParser, CollectsEveryErrorInOrderWithoutThrowing) {
  Opts o;
  ArgParser p = makeParser(&o);
  EXPECT_FALSE(p.parse({"--window", "0", "--start", "-2", "--rate", "x", "--bogus", "--loop=1",
                        "--mode", "c", "--compress", "maybe", "positional", "--window=12abc",
                        "--start"}));
  const std::vector<std::string> expected = {
      "--window: expected an integer in [1, 100], got '0'",
      "--start: expected an integer >= 0, got '-2'",
      "--rate: expected a number >= 0, got 'x'",
      "unknown option '--bogus'",
      "--loop takes no value",
      "--mode: a or b, not 'c'",
      "--compress: expected true/false, 1/0, yes/no or on/off, got 'maybe'",
      "unknown option 'positional'",
      "--window: expected an integer in [1, 100], got '12abc'",
      "--start needs a value"};
  EXPECT_EQ(p.errors(), expected);
  // Rejected values leave the defaults untouched.
  EXPECT_EQ(o.window, 10);
  EXPECT_EQ(o.start, 0);
  EXPECT_EQ(o.rate, 1.0);
  EXPECT_EQ(o.mode, "a");
  EXPECT_FALSE(o.loop);
  p.addError("--x is required");
  EXPECT_EQ(p.errors().back(), "--x is required");
  EXPECT_FALSE(p.ok());
}

TEST(ArgParser, HelpIsAFlagNotAnError) {
  for (const char* h : {"-h", "--help"}) {
    Opts o;
    ArgParser p = makeParser(&o);
    EXPECT_TRUE(p.parse({"--window", "3", h}));
    EXPECT_TRUE(p.help());
    EXPECT_EQ(o.window, 3);
  }
  Opts o;
  ArgParser p = makeParser(&o);
  EXPECT_FALSE(p.parse({"--bogus", "--help"}));  // errors still collected; main shows help
  EXPECT_TRUE(p.help());
  EXPECT_EQ(p.errors().size(), 1u);
}

TEST(ArgParser, BoundsAndStrictNumbers) {
  int i = 0;
  double d = 0;
  int64_t l = 0;
  ArgParser p;
  p.option("--i", &i).option("--d", &d, -1.0, 1.0).option("--l", &l, int64_t{-5}, int64_t{5});
  EXPECT_TRUE(p.parse({"--i", "-2147483648", "--d", "1e0", "--l=-5"}));
  EXPECT_EQ(i, -2147483648LL);
  EXPECT_EQ(d, 1.0);
  EXPECT_EQ(l, -5);
  ArgParser q;
  q.option("--i", &i).option("--d", &d, -1.0, 1.0).option("--u", &d, -1e300, 0.5);
  EXPECT_FALSE(q.parse({"--i", "2147483648", "--d", "nan", "--d", "inf", "--d", "1.5", "--i", "",
                        "--i", " 3"}));
  ASSERT_EQ(q.errors().size(), 6u);
  EXPECT_EQ(q.errors()[0], "--i: expected an integer, got '2147483648'");
  EXPECT_EQ(q.errors()[3], "--d: expected a number in [-1, 1], got '1.5'");
  ArgParser r;
  r.option("--u", &d, -std::numeric_limits<double>::infinity(), 0.5);
  EXPECT_FALSE(r.parse({"--u", "0.75"}));
  EXPECT_EQ(r.errors()[0], "--u: expected a number <= 0.5, got '0.75'");
}

TEST(ArgParser, AliasesAndFlagActions) {
  std::string out;
  int calls = 0;
  ArgParser p;
  p.option("--output", &out).option("-o", &out).flag("--count", [&] { ++calls; });
  EXPECT_TRUE(p.parse({"-o", "a.log", "--count", "--count"}));
  EXPECT_EQ(out, "a.log");
  EXPECT_EQ(calls, 2);
  EXPECT_EQ(p.names(), (std::vector<std::string>{"--output", "-o", "--count"}));
  ArgParser q;
  q.option("-o", &out);
  EXPECT_FALSE(q.parse({"-o=b"}));  // '=' splits only "--" options
  EXPECT_EQ(q.errors()[0], "unknown option '-o=b'");
}

TEST(ArgParser, ConversionsAndArgv) {
  double d = 7;
  EXPECT_FALSE(parseDouble("1.5x", &d));
  EXPECT_EQ(d, 7);
  EXPECT_TRUE(parseDouble("-2.5e-3", &d));
  EXPECT_EQ(d, -2.5e-3);
  int64_t l = 0;
  EXPECT_FALSE(parseInt64("99999999999999999999", &l));
  EXPECT_TRUE(parseInt64("-9000000000", &l));
  EXPECT_EQ(l, -9000000000LL);
  bool b = false;
  for (const char* t : {"true", "1", "yes", "on"}) {
    b = false;
    EXPECT_TRUE(parseBool(t, &b));
    EXPECT_TRUE(b);
  }
  EXPECT_FALSE(parseBool("TRUE", &b));
  const char* argv[] = {"prog", "--a", "b"};
  EXPECT_EQ(argsFromArgv(3, argv), (std::vector<std::string>{"--a", "b"}));
}

TEST(ArgParser, ProgressFlagWinsElseTerminal) {
  EXPECT_TRUE(progressEnabled({"--x", "--progress"}, true));
  EXPECT_FALSE(progressEnabled({"--no-progress"}, false));
  // Neither flag: decided by isatty(stderr); ctest runs with stderr on a pipe.
  EXPECT_EQ(progressEnabled({"--x"}, true), ::isatty(2) == 1);
}

}  // namespace
}  // namespace pplvo
