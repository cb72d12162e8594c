#include <gtest/gtest.h>

#include <cmath>

#include "pplvo/core/config_visitor.h"

namespace pplvo::config {
namespace {

struct Inner {
  double alpha = 0.02;
  int window = 10;
};
struct Outer {
  std::string name = "x";
  bool enabled = true;
  Inner inner;
};

template <class V>
void visit(V& v, Inner& o) {
  v.field("alpha", o.alpha, "plane scale (paper: 0.02)", atLeast(0));
  v.field("window", o.window, "frames", atLeast(1));
}

template <class V>
void visit(V& v, Outer& o) {
  v.field("name", o.name, "a name");
  v.field("enabled", o.enabled, "on or off");
  v.section("inner", "the inner part", [&] { visit(v, o.inner); });
}

const auto kOuter = [](auto& v, Outer& o) { visit(v, o); };

TEST(ConfigVisitor, LoadsOverridesAndKeepsDefaults) {
  Outer o;
  EXPECT_TRUE(readConfig(YAML::Load("name: y\ninner:\n  window: 5\n"), &o, kOuter).empty());
  EXPECT_EQ(o.name, "y");
  EXPECT_EQ(o.inner.window, 5);
  EXPECT_DOUBLE_EQ(o.inner.alpha, 0.02);
}

TEST(ConfigVisitor, ReportsAllErrorsTogether) {
  Outer o;
  const std::vector<std::string> errors = readConfig(
      YAML::Load("nmae: y\nenabled: maybe\ninner:\n  window: ten\n  beta: 1\n"), &o, kOuter);
  ASSERT_FALSE(errors.empty()) << "expected errors";
  const std::string msg = joinErrors("test", errors);
  EXPECT_NE(msg.find("nmae: unknown key"), std::string::npos) << msg;
  EXPECT_NE(msg.find("inner.beta: unknown key"), std::string::npos) << msg;
  EXPECT_NE(msg.find("inner.window"), std::string::npos) << msg;
  EXPECT_NE(msg.find("enabled"), std::string::npos) << msg;
  EXPECT_NE(msg.find("4 error"), std::string::npos) << msg;
  EXPECT_EQ(o.name, "x");  // nothing applied
}

TEST(ConfigVisitor, DumpThenLoadRoundTrips) {
  Outer o;
  o.name = "dumped: with a colon";
  o.inner.alpha = 0.5;
  const std::string dump = dumpConfig(o, kOuter, "# header");
  Outer back;
  EXPECT_TRUE(readConfig(YAML::Load(dump), &back, kOuter).empty()) << dump;
  EXPECT_EQ(back.name, "dumped: with a colon");
  EXPECT_DOUBLE_EQ(back.inner.alpha, 0.5);
  EXPECT_NE(dump.find("# plane scale"), std::string::npos) << dump;
  EXPECT_NE(dump.find("Range: >= 1."), std::string::npos) << dump;
}

TEST(ConfigVisitor, RangesAreCheckedAndDescribed) {
  Outer o;
  const auto errors = readConfig(YAML::Load("inner: {window: 0, alpha: -1.5}"), &o, kOuter);
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0], "inner.alpha: -1.5 is out of range (must be >= 0.0)");
  EXPECT_EQ(errors[1], "inner.window: 0 is out of range (must be >= 1)");
  EXPECT_EQ(o.inner.window, 10);
  EXPECT_EQ(describe(openClosed(0, 180), false), "(0.0, 180.0]");
  EXPECT_EQ(describe(between(1, 2), true), "[1, 2]");
  EXPECT_EQ(describe(greaterThan(1), false), "> 1.0");
  EXPECT_EQ(formatNumber(1.425e-3), "0.001425");
  EXPECT_EQ(formatNumber(1e-5), "1.0e-05");
  EXPECT_EQ(formatNumber(40), "40.0");
  EXPECT_EQ(std::strtod(formatNumber(0.1 + 0.2).c_str(), nullptr), 0.1 + 0.2);
}

TEST(ConfigVisitor, ForbidPathsAndForeignRootKeys) {
  Outer o;
  const auto forbid_window = [](auto& v, Outer& x) {
    ForbidPaths<std::remove_reference_t<decltype(v)>> f(v, {"inner.window"}, "set elsewhere");
    visit(f, x);
  };
  auto errors = readConfig(YAML::Load("inner: {window: 3}"), &o, forbid_window);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0], "inner.window: not settable here (set elsewhere)");
  // Keys of other readers of the same file: errors unless declared foreign.
  EXPECT_EQ(readConfig(YAML::Load("other: {a: 1}\nname: z"), &o, kOuter).size(), 1u);
  EXPECT_TRUE(readConfig(YAML::Load("other: {a: 1}\nname: z"), &o, kOuter, true).empty());
  EXPECT_EQ(o.name, "z");
}

TEST(ConfigVisitor, CommandLineFileSetShortcutsThenRules) {
  const std::vector<Shortcut> shortcuts = {{"--window", "inner.window", "N  frames"}};
  ConfigArgs args;
  ArgParser p;
  addConfigOptions(p, &args, shortcuts);
  ASSERT_TRUE(p.parse({"--window", "4", "--set", "inner.window=2", "--set=name=n"}));
  Outer o;
  int rule_calls = 0;
  auto rules = [&](const Outer& x) {
    ++rule_calls;
    EXPECT_EQ(x.inner.window, 4);  // after the shortcut, which comes after --set
    return std::vector<std::string>{};
  };
  EXPECT_TRUE(applyConfigArgs(args, shortcuts, &o, kOuter, rules).empty());
  EXPECT_EQ(rule_calls, 1);
  EXPECT_EQ(o.name, "n");

  // A shortcut has the key's range; every problem is reported, the rules are not run.
  ConfigArgs bad;
  ArgParser q;
  addConfigOptions(q, &bad, shortcuts);
  ASSERT_TRUE(q.parse({"--window", "0", "--config", "/nonexistent.yaml", "--set", "x"}));
  const auto errors = applyConfigArgs(bad, shortcuts, &o, kOuter, rules);
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_NE(errors[0].find("/nonexistent.yaml: cannot open"), std::string::npos) << errors[0];
  EXPECT_EQ(errors[1], "--window 0: inner.window: 0 is out of range (must be >= 1)");
  EXPECT_EQ(rule_calls, 1);
  const std::string usage = configUsage("a file", "name=x", shortcuts);
  EXPECT_NE(usage.find("--window N"), std::string::npos) << usage;
  EXPECT_NE(usage.find("(= --set inner.window)"), std::string::npos) << usage;
}

}  // namespace
}  // namespace pplvo::config
