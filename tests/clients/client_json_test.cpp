// locctl's JSON output: strings escaped per RFC 8259, numbers that read back exactly, null for
// what JSON cannot represent.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>

#include "json.hpp"

namespace locd::locctl {
namespace {

TEST(LocctlJson, StringsEscapeQuotesBackslashesAndControlCharacters) {
  EXPECT_EQ(json_string("plain"), "\"plain\"");
  EXPECT_EQ(json_string("say \"hi\""), "\"say \\\"hi\\\"\"");
  EXPECT_EQ(json_string("C:\\maps\\x.yaml"), "\"C:\\\\maps\\\\x.yaml\"");
  EXPECT_EQ(json_string("line 1\nline 2\r\tend"), "\"line 1\\nline 2\\r\\tend\"");
  EXPECT_EQ(json_string(std::string("\x01\x1f\b\f", 4)), "\"\\u0001\\u001f\\b\\f\"");
  EXPECT_EQ(json_string(std::string("nul\0byte", 8)), "\"nul\\u0000byte\"");
  EXPECT_EQ(json_string("café ±0.5°"), "\"café ±0.5°\"");  // UTF-8 passes through
  EXPECT_EQ(json_string("/"), "\"/\"");
}

TEST(LocctlJson, NumbersReadBackExactlyAndNonFiniteBecomesNull) {
  for (const double v : {0.0, -0.0, 1.0, 0.1, -3.141592653589793, 1e-300, 6.02214076e23,
                         std::numeric_limits<double>::max(), std::numeric_limits<double>::denorm_min()}) {
    const std::string text = json_number(v);
    EXPECT_EQ(std::strtod(text.c_str(), nullptr), v) << text;
  }
  EXPECT_EQ(json_number(std::numeric_limits<double>::quiet_NaN()), "null");
  EXPECT_EQ(json_number(std::numeric_limits<double>::infinity()), "null");
  EXPECT_EQ(json_number(-std::numeric_limits<double>::infinity()), "null");
}

TEST(LocctlJson, ObjectsAndArraysKeepOrderAndTypes) {
  const std::string object = JsonObject()
                                 .add("robot", "r\"1")
                                 .add("ok", false)
                                 .add("count", uint64_t{18446744073709551615ull})
                                 .add("stamp_ns", int64_t{-5})
                                 .add("x", 0.5)
                                 .add("consumes", std::vector<std::string>{"odometry", "scan"})
                                 .add("none", std::vector<std::string>{})
                                 .add_raw("nested", JsonObject().add("a", 1).str())
                                 .str();
  EXPECT_EQ(object,
            "{\"robot\":\"r\\\"1\",\"ok\":false,\"count\":18446744073709551615,\"stamp_ns\":-5,\"x\":0.5,"
            "\"consumes\":[\"odometry\",\"scan\"],\"none\":[],\"nested\":{\"a\":1}}");
  EXPECT_EQ(JsonObject().str(), "{}");
  EXPECT_EQ(json_array({"1", "\"b\"", "{}"}), "[1,\"b\",{}]");
}

}  // namespace
}  // namespace locd::locctl
