#include "locd/sdk/params.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace locd {
namespace {

std::string format_number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? ", " : "") + items[i];
  return out;
}

std::string scalar_text(const YAML::Node& node) {
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  if (node.IsMap()) return "a map";
  return "null";
}

}  // namespace

bool Range::contains(double v) const {
  if (!std::isfinite(v)) return false;
  const bool lo_ok = min_open ? v > min : v >= min;
  const bool hi_ok = max_open ? v < max : v <= max;
  return lo_ok && hi_ok;
}

std::string Range::describe() const {
  return std::string(min_open ? "(" : "[") + format_number(min) + ", " + format_number(max) +
         (max_open ? ")" : "]");
}

Params::Params(YAML::Node node, std::string path) : node_(std::move(node)), path_(std::move(path)) {}

Params Params::parse(const std::string& yaml_text, const std::string& source_name) {
  try {
    YAML::Node node = YAML::Load(yaml_text);
    if (!node.IsDefined() || node.IsNull()) node = YAML::Node(YAML::NodeType::Map);
    if (!node.IsMap()) {
      throw ConfigError(source_name + ": expected a YAML map of parameters at the top level, got " +
                        scalar_text(node));
    }
    return Params(node, "");
  } catch (const YAML::Exception& e) {
    throw ConfigError(source_name + ": malformed YAML at line " + std::to_string(e.mark.line + 1) +
                      ", column " + std::to_string(e.mark.column + 1) + ": " + e.msg);
  }
}

Params Params::load_file(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw ConfigError("cannot read config file '" + file + "'");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return parse(buffer.str(), file);
}

std::string Params::key_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

bool Params::has(const std::string& key) const {
  return node_.IsMap() && node_[key].IsDefined() && !node_[key].IsNull();
}

Params Params::child(const std::string& key) const {
  if (!has(key)) return Params(YAML::Node(YAML::NodeType::Map), key_path(key));
  YAML::Node c = node_[key];
  if (!c.IsMap()) fail(key, "is " + scalar_text(c) + "; expected a map of parameters");
  return Params(c, key_path(key));
}

std::string Params::where(const std::string& key) const {
  YAML::Node n = key.empty() || !has(key) ? node_ : node_[key];
  const YAML::Mark m = n.Mark();
  if (m.is_null()) return "";
  return "line " + std::to_string(m.line + 1) + ", column " + std::to_string(m.column + 1);
}

void Params::fail(const std::string& key, const std::string& what) const {
  const std::string at = where(key);
  throw ConfigError("parameter '" + key_path(key) + "'" + (at.empty() ? "" : " (" + at + ")") +
                    " " + what);
}

double Params::number(const std::string& key, double default_value, Range range) const {
  if (!has(key)) return default_value;
  return required_number(key, range);
}

double Params::required_number(const std::string& key, Range range) const {
  if (!has(key)) fail(key, "is missing; expected a number in " + range.describe());
  const YAML::Node n = node_[key];
  double v = 0;
  if (!n.IsScalar() || !YAML::convert<double>::decode(n, v)) {
    fail(key, "= " + scalar_text(n) + " is not a number; expected a number in " + range.describe());
  }
  if (!range.contains(v)) {
    fail(key, "= " + format_number(v) + " is out of range; allowed: " + range.describe());
  }
  return v;
}

long Params::integer(const std::string& key, long default_value, long min, long max) const {
  if (!has(key)) return default_value;
  const YAML::Node n = node_[key];
  long v = 0;
  if (!n.IsScalar() || !YAML::convert<long>::decode(n, v)) {
    fail(key, "= " + scalar_text(n) + " is not an integer; expected an integer in [" +
                  std::to_string(min) + ", " + std::to_string(max) + "]");
  }
  if (v < min || v > max) {
    fail(key, "= " + std::to_string(v) + " is out of range; allowed: [" + std::to_string(min) +
                  ", " + std::to_string(max) + "]");
  }
  return v;
}

bool Params::flag(const std::string& key, bool default_value) const {
  if (!has(key)) return default_value;
  const YAML::Node n = node_[key];
  bool v = false;
  if (!n.IsScalar() || !YAML::convert<bool>::decode(n, v)) {
    fail(key, "= " + scalar_text(n) + " is not a boolean; expected true or false");
  }
  return v;
}

std::string Params::text(const std::string& key, const std::string& default_value,
                         const std::vector<std::string>& allowed) const {
  if (!has(key)) return default_value;
  const YAML::Node n = node_[key];
  if (!n.IsScalar()) fail(key, "is " + scalar_text(n) + "; expected a string");
  const std::string v = n.Scalar();
  if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), v) == allowed.end()) {
    fail(key, "= '" + v + "' is not allowed; allowed: " + join(allowed));
  }
  return v;
}

std::string Params::required_text(const std::string& key) const {
  if (!has(key)) fail(key, "is missing; expected a string");
  return text(key, "");
}

std::vector<double> Params::numbers(const std::string& key, const std::vector<double>& default_value,
                                    size_t size, Range range) const {
  if (!has(key)) return default_value;
  const YAML::Node n = node_[key];
  const std::string expected =
      (size ? "a list of " + std::to_string(size) + " numbers" : std::string("a list of numbers")) +
      " in " + range.describe();
  if (!n.IsSequence()) fail(key, "is " + scalar_text(n) + "; expected " + expected);
  if (size && n.size() != size) {
    fail(key, "has " + std::to_string(n.size()) + " entries; expected " + expected);
  }
  std::vector<double> out;
  out.reserve(n.size());
  for (size_t i = 0; i < n.size(); ++i) {
    double v = 0;
    if (!n[i].IsScalar() || !YAML::convert<double>::decode(n[i], v) || !range.contains(v)) {
      fail(key, "entry " + std::to_string(i) + " = " + scalar_text(n[i]) + " is not allowed; expected " +
                    expected);
    }
    out.push_back(v);
  }
  return out;
}

void Params::expect_only(std::initializer_list<const char*> known) const {
  if (!node_.IsMap()) return;
  for (const auto& item : node_) {
    const std::string key = item.first.as<std::string>();
    if (std::none_of(known.begin(), known.end(), [&](const char* k) { return key == k; })) {
      std::vector<std::string> names(known.begin(), known.end());
      const YAML::Mark m = item.first.Mark();
      throw ConfigError("unknown parameter '" + key_path(key) + "' (line " +
                        std::to_string(m.line + 1) + ", column " + std::to_string(m.column + 1) +
                        "); known: " + join(names));
    }
  }
}

}  // namespace locd
