// Validated access to a plugin's (or the server's) YAML parameters. Every failure is a
// ConfigError whose message names the key, the value, where it stands (line, column) and what
// is allowed, so a robot sees exactly what to fix on its status topic.
#pragma once

#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <limits>
#include <string>
#include <vector>

#include "locd/sdk/errors.hpp"

namespace locd {

// Allowed interval for a number; open ends exclude the bound.
struct Range {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;
  bool max_open = false;

  static Range closed(double lo, double hi) { return {lo, hi, false, false}; }
  static Range positive() { return {0.0, std::numeric_limits<double>::infinity(), true, false}; }
  static Range non_negative() { return {0.0, std::numeric_limits<double>::infinity(), false, false}; }
  static Range open(double lo, double hi) { return {lo, hi, true, true}; }
  bool contains(double v) const;
  std::string describe() const;  // e.g. "(0, 1]"
};

class Params {
 public:
  Params() = default;
  Params(YAML::Node node, std::string path);

  // Parses YAML text; a syntax error becomes a ConfigError naming source, line and column.
  static Params parse(const std::string& yaml_text, const std::string& source_name);
  static Params load_file(const std::string& file);

  bool has(const std::string& key) const;
  Params child(const std::string& key) const;  // missing child -> empty map
  const YAML::Node& node() const { return node_; }
  const std::string& path() const { return path_; }
  std::string key_path(const std::string& key) const;  // "feature_ekf.gate" for "gate"

  double number(const std::string& key, double default_value, Range range = {}) const;
  double required_number(const std::string& key, Range range = {}) const;
  long integer(const std::string& key, long default_value, long min, long max) const;
  bool flag(const std::string& key, bool default_value) const;
  std::string text(const std::string& key, const std::string& default_value,
                   const std::vector<std::string>& allowed = {}) const;
  std::string required_text(const std::string& key) const;
  // A list of exactly `size` numbers (size 0 = any length).
  std::vector<double> numbers(const std::string& key, const std::vector<double>& default_value,
                              size_t size = 0, Range range = {}) const;

  // Fails on any key not in `known`, listing the known ones (catches typos in configs).
  void expect_only(std::initializer_list<const char*> known) const;

  // "line 4, column 7" for a key (or the node itself), for messages.
  std::string where(const std::string& key = {}) const;
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;

 private:
  YAML::Node node_;
  std::string path_;
};

}  // namespace locd
