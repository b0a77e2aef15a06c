#include "locd/sdk/robot_id.hpp"

#include <stdexcept>

#include "locd/sdk/text.hpp"

namespace locd {
namespace {

bool allowed(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '.' ||
         c == '-';
}

}  // namespace

std::string robot_id_error(std::string_view robot_id) {
  constexpr const char* kAllowed = "; allowed: 1-64 characters of [A-Za-z0-9_.-]";
  if (robot_id.empty()) return std::string("robot_id is empty") + kAllowed;
  if (robot_id.size() > kMaxRobotIdLength) {
    return "robot_id '" + escaped(robot_id, 32) + "' is " + std::to_string(robot_id.size()) + " characters" + kAllowed;
  }
  for (const char c : robot_id) {
    if (!allowed(c)) {
      return "robot_id '" + escaped(robot_id) + "' contains '" + escaped(std::string_view(&c, 1)) + "'" + kAllowed;
    }
  }
  return {};
}

void check_robot_id(std::string_view robot_id) {
  if (std::string error = robot_id_error(robot_id); !error.empty()) throw std::invalid_argument(error);
}

}  // namespace locd
