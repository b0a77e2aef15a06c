#include <gtest/gtest.h>

#include "error_of.hpp"
#include "locd/sdk/params.hpp"

using locd::ConfigError;
using locd::Params;
using locd::Range;

using locd::test::error_of;

TEST(Params, MalformedYamlNamesLineAndColumn) {
  const std::string msg = error_of([] { Params::parse("a: 1\nb: [1, 2\nc: 3\n", "robot.yaml"); });
  EXPECT_NE(msg.find("robot.yaml"), std::string::npos) << msg;
  EXPECT_NE(msg.find("line"), std::string::npos) << msg;
  EXPECT_NE(msg.find("column"), std::string::npos) << msg;
}

TEST(Params, TopLevelMustBeAMap) {
  EXPECT_NE(error_of([] { Params::parse("- 1\n- 2\n", "x.yaml"); }).find("map"), std::string::npos);
  EXPECT_TRUE(Params::parse("", "empty.yaml").node().IsMap());
}

TEST(Params, OutOfRangeNamesKeyValueAndRange) {
  const Params p(Params::parse("gate: 1.5\n", "c.yaml").node(), "feature_ekf");
  const std::string msg = error_of([&] { p.number("gate", 0.99, Range::open(0, 1)); });
  EXPECT_NE(msg.find("'feature_ekf.gate'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("1.5"), std::string::npos) << msg;
  EXPECT_NE(msg.find("(0, 1)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("line 1, column 7"), std::string::npos) << msg;
}

TEST(Params, TypesAndDefaults) {
  const Params p = Params::parse("n: 3\nf: true\ns: nn\nv: [1, 2, 3]\nbad: abc\n", "c.yaml");
  EXPECT_EQ(p.integer("n", 0, 0, 10), 3);
  EXPECT_EQ(p.integer("missing", 7, 0, 10), 7);
  EXPECT_TRUE(p.flag("f", false));
  EXPECT_EQ(p.text("s", "", {"nn", "pda"}), "nn");
  EXPECT_EQ(p.numbers("v", {}, 3), (std::vector<double>{1, 2, 3}));
  EXPECT_THROW(p.numbers("v", {}, 2), ConfigError);
  EXPECT_THROW(p.number("bad", 0.0), ConfigError);
  EXPECT_THROW(p.integer("n", 0, 4, 10), ConfigError);
  EXPECT_NE(error_of([&] { p.text("s", "", {"jcbb", "pda"}); }).find("allowed: jcbb, pda"), std::string::npos);
  EXPECT_THROW(p.required_number("missing"), ConfigError);
}

TEST(Params, NanIsNeverInRange) {
  const Params p = Params::parse("x: .nan\n", "c.yaml");
  EXPECT_THROW(p.number("x", 0.0), ConfigError);
}

TEST(Params, UnknownKeysAreListed) {
  const Params p = Params::parse("gate: 1\ngaet: 2\n", "c.yaml");
  const std::string msg = error_of([&] { p.expect_only({"gate", "map"}); });
  EXPECT_NE(msg.find("'gaet'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("known: gate, map"), std::string::npos) << msg;
}

TEST(Params, ChildKeepsPath) {
  const Params p(Params::parse("noise: {v: -1}\n", "c.yaml").node(), "ekf");
  const std::string msg = error_of([&] { p.child("noise").number("v", 0.1, Range::non_negative()); });
  EXPECT_NE(msg.find("'ekf.noise.v'"), std::string::npos) << msg;
}
