// Session ownership, the bridge's half: which of a robot's inputs (its session requests, initial
// poses, map-save requests and sensor topics) still have a live writer, as the server's readers
// see the robot's DDS instances. A robot is present while at least one input has; the bridge
// tells the Server when a robot becomes present or absent (Server::on_robot_writers), and the
// Server ends an absent robot's session after a grace period.
#pragma once

#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

namespace locd::server {

class RobotWriterPresence {
 public:
  static constexpr unsigned kMaxInputs = 32;

  // Robots tracked at once; beyond, a new robot is not tracked (it stays as present as it was).
  explicit RobotWriterPresence(size_t max_robots) : max_robots_(max_robots) {}

  // Input `input` (0..kMaxInputs-1) of `robot_id` received a sample from a live writer in the
  // robot's partition (alive), or its writers are all gone. Returns the robot's new presence when
  // this changed it, nullopt otherwise.
  std::optional<bool> update(const std::string& robot_id, unsigned input, bool alive);

  // True while some input of `robot_id` has a live writer.
  bool present(const std::string& robot_id) const;

 private:
  mutable std::mutex mutex_;
  std::unordered_map<std::string, uint32_t> live_inputs_;  // only robots with at least one
  size_t max_robots_;
};

}  // namespace locd::server
