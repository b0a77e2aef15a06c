#include "locd/server/writer_presence.hpp"

namespace locd::server {

std::optional<bool> RobotWriterPresence::update(const std::string& robot_id, unsigned input, bool alive) {
  const uint32_t bit = 1u << (input % kMaxInputs);
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = live_inputs_.find(robot_id);
  if (alive) {
    if (it != live_inputs_.end()) {
      it->second |= bit;
      return std::nullopt;
    }
    if (live_inputs_.size() >= max_robots_) return std::nullopt;
    live_inputs_.emplace(robot_id, bit);
    return true;
  }
  if (it == live_inputs_.end()) return std::nullopt;
  it->second &= ~bit;
  if (it->second != 0) return std::nullopt;
  live_inputs_.erase(it);
  return false;
}

bool RobotWriterPresence::present(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return live_inputs_.count(robot_id) > 0;
}

}  // namespace locd::server
