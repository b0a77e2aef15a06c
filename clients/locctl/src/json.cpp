#include "json.hpp"

#include <cmath>
#include <cstdio>

namespace locd::locctl {

std::string json_string(const std::string& text) {
  std::string out;
  out.reserve(text.size() + 2);
  out += '"';
  for (const char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char escaped[8];
          std::snprintf(escaped, sizeof(escaped), "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          out += escaped;
        } else {
          out += c;
        }
    }
  }
  out += '"';
  return out;
}

std::string json_number(double value) {
  if (!std::isfinite(value)) return "null";
  char text[32];
  std::snprintf(text, sizeof(text), "%.17g", value);
  return text;
}

JsonObject& JsonObject::add_raw(const std::string& key, const std::string& json) {
  members_.push_back(json_string(key) + ":" + json);
  return *this;
}
JsonObject& JsonObject::add(const std::string& key, const std::string& value) { return add_raw(key, json_string(value)); }
JsonObject& JsonObject::add(const std::string& key, const char* value) { return add_raw(key, json_string(value)); }
JsonObject& JsonObject::add(const std::string& key, double value) { return add_raw(key, json_number(value)); }
JsonObject& JsonObject::add(const std::string& key, int64_t value) { return add_raw(key, std::to_string(value)); }
JsonObject& JsonObject::add(const std::string& key, uint64_t value) { return add_raw(key, std::to_string(value)); }
JsonObject& JsonObject::add(const std::string& key, int value) { return add_raw(key, std::to_string(value)); }
JsonObject& JsonObject::add(const std::string& key, bool value) { return add_raw(key, value ? "true" : "false"); }
JsonObject& JsonObject::add(const std::string& key, const std::vector<std::string>& values) {
  std::vector<std::string> elements;
  elements.reserve(values.size());
  for (const auto& v : values) elements.push_back(json_string(v));
  return add_raw(key, json_array(elements));
}

std::string JsonObject::str() const {
  std::string out = "{";
  for (size_t i = 0; i < members_.size(); ++i) {
    if (i) out += ',';
    out += members_[i];
  }
  return out + "}";
}

std::string json_array(const std::vector<std::string>& elements_as_json) {
  std::string out = "[";
  for (size_t i = 0; i < elements_as_json.size(); ++i) {
    if (i) out += ',';
    out += elements_as_json[i];
  }
  return out + "]";
}

}  // namespace locd::locctl
