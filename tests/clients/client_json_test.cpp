// locctl's JSON output (nlohmann-json, as locctl writes it): strings escaped per RFC 8259, numbers
// that read back exactly, null for what JSON cannot represent, keys in the order written.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>

#include "json.hpp"

namespace locd::locctl {
namespace {

std::string json_string(const std::string& text) { return Json(text).dump(); }
std::string json_number(double value) { return Json(value).dump(); }

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
  const std::string object = Json{{"robot", "r\"1"},
                                  {"ok", false},
                                  {"count", uint64_t{18446744073709551615ull}},
                                  {"stamp_ns", int64_t{-5}},
                                  {"x", 0.5},
                                  {"consumes", std::vector<std::string>{"odometry", "scan"}},
                                  {"none", std::vector<std::string>{}},
                                  {"nested", Json{{"a", 1}}}}
                                 .dump();
  EXPECT_EQ(object,
            "{\"robot\":\"r\\\"1\",\"ok\":false,\"count\":18446744073709551615,\"stamp_ns\":-5,\"x\":0.5,"
            "\"consumes\":[\"odometry\",\"scan\"],\"none\":[],\"nested\":{\"a\":1}}");
  EXPECT_EQ(Json::object().dump(), "{}");
  EXPECT_EQ(Json::array({1, "b", Json::object()}).dump(), "[1,\"b\",{}]");
}

}  // namespace
}  // namespace locd::locctl
