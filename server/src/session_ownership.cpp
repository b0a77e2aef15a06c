// Session ownership: a session started by a remote request lives while its robot has a live
// writer (Server::on_robot_writers, from the bridge's RobotWriterPresence) and ends
// session_grace_s after the last one went. Kept apart from server.cpp: it only reads and
// erases sessions_ under the same mutex.
#include <sstream>
#include <vector>

#include "locd/server/server.hpp"

namespace locd::server {
namespace {

bool is_boot_session(const ServerConfig& config, const std::string& robot_id) {
  for (const auto& boot : config.sessions) {
    if (boot.robot_id == robot_id) return true;
  }
  return false;
}

}  // namespace

void Server::on_robot_writers(const std::string& robot_id, bool alive) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (alive) {
    ownerless_since_.erase(robot_id);
    return;
  }
  if (!sessions_.count(robot_id) || is_boot_session(config_, robot_id)) return;
  ownerless_since_.emplace(robot_id, std::chrono::steady_clock::now());
}

void Server::end_ownerless_sessions() {
  const auto now = std::chrono::steady_clock::now();
  const auto grace = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(config_.session_grace_s));
  std::vector<std::shared_ptr<Session>> ended;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = ownerless_since_.begin(); it != ownerless_since_.end();) {
      const auto session = sessions_.find(it->first);
      if (session == sessions_.end()) {
        it = ownerless_since_.erase(it);
      } else if (now - it->second >= grace) {
        ended.push_back(session->second);
        requests_.erase(session->first);  // the robot is gone: its request is not served again
        forget_locked(session);
        it = ownerless_since_.erase(it);
      } else {
        ++it;
      }
    }
  }
  publish_claims();
  for (const auto& session : ended) {
    std::ostringstream message;
    message << "session ended: no live writer of robot '" << session->robot_id()
            << "' (session requests, initial poses, map saves, sensor data) for " << config_.session_grace_s
            << " s (session_grace_s)";
    logger_.log(LogLevel::kInfo, session->robot_id(), message.str());
    session->stop(0, message.str());
    if (observer_) observer_->session_ended(session->robot_id());
  }
}

}  // namespace locd::server
