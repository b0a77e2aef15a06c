// What a robot id may be. Robot ids name DDS partitions (`robot.<id>`), log subjects and status
// instances, so they are plain: 1-64 characters of [A-Za-z0-9_.-]. No wildcard, space or control
// character can reach a partition name or a log line through one.
#pragma once

#include <string>
#include <string_view>

namespace locd {

inline constexpr size_t kMaxRobotIdLength = 64;

// Empty when `robot_id` is allowed; otherwise why not, naming the id (escaped) and what is allowed.
std::string robot_id_error(std::string_view robot_id);

// Throws std::invalid_argument with robot_id_error's message.
void check_robot_id(std::string_view robot_id);

}  // namespace locd
