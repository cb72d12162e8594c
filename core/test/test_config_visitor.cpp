#include <gtest/gtest.h>

#include "pplvo/core/config_visitor.h"

namespace pplvo {
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
void visit(V& v, Outer& o) {
  v.field("name", o.name, "a name");
  v.field("enabled", o.enabled);
  v.section("inner", [&] {
    v.field("alpha", o.inner.alpha, "plane scale (paper: 0.02)");
    v.field("window", o.inner.window);
  });
}

TEST(ConfigVisitor, LoadsOverridesAndKeepsDefaults) {
  Outer o;
  YamlLoader l(YAML::Load("name: y\ninner:\n  window: 5\n"));
  visit(l, o);
  l.finish();
  EXPECT_EQ(o.name, "y");
  EXPECT_EQ(o.inner.window, 5);
  EXPECT_DOUBLE_EQ(o.inner.alpha, 0.02);
}

TEST(ConfigVisitor, ReportsAllErrorsTogether) {
  Outer o;
  YamlLoader l(YAML::Load("nmae: y\nenabled: maybe\ninner:\n  window: ten\n  beta: 1\n"));
  visit(l, o);
  try {
    l.finish();
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("nmae: unknown key"), std::string::npos) << msg;
    EXPECT_NE(msg.find("inner.beta: unknown key"), std::string::npos) << msg;
    EXPECT_NE(msg.find("inner.window"), std::string::npos) << msg;
    EXPECT_NE(msg.find("enabled"), std::string::npos) << msg;
    EXPECT_NE(msg.find("4 error"), std::string::npos) << msg;
  }
}

TEST(ConfigVisitor, DumpThenLoadRoundTrips) {
  Outer o;
  o.name = "dumped";
  o.inner.alpha = 0.5;
  YamlDumper d;
  visit(d, o);
  Outer back;
  YamlLoader l(YAML::Load(d.str()));
  visit(l, back);
  l.finish();
  EXPECT_EQ(back.name, "dumped");
  EXPECT_DOUBLE_EQ(back.inner.alpha, 0.5);
  EXPECT_NE(d.str().find("# plane scale"), std::string::npos);
}

}  // namespace
}  // namespace pplvo
