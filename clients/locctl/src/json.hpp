// Just enough JSON output for locctl --json: an escaper and a flat object builder.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace locd::locctl {

// A JSON string literal (with quotes) for UTF-8 text: escapes ", \ and control characters.
std::string json_string(const std::string& text);
// A JSON number; NaN and infinities become null (JSON has no such numbers).
std::string json_number(double value);

class JsonObject {
 public:
  JsonObject& add(const std::string& key, const std::string& value);
  JsonObject& add(const std::string& key, const char* value);
  JsonObject& add(const std::string& key, double value);
  JsonObject& add(const std::string& key, int64_t value);
  JsonObject& add(const std::string& key, uint64_t value);
  JsonObject& add(const std::string& key, int value);
  JsonObject& add(const std::string& key, bool value);
  JsonObject& add(const std::string& key, const std::vector<std::string>& values);
  JsonObject& add_raw(const std::string& key, const std::string& json);  // already JSON
  std::string str() const;

 private:
  std::vector<std::string> members_;
};

std::string json_array(const std::vector<std::string>& elements_as_json);

}  // namespace locd::locctl
