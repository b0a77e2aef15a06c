// Told when a robot's session gets a plugin config and when the session ends, for parts that
// keep something per session beside the plugin (the ROS 2 bridge: a robot's ROS 2 endpoints
// appear when its session starts and go when it stops).
#pragma once

#include <string>

#include "locd/sdk/plugin_config.hpp"

namespace locd::server {

class SessionObserver {
 public:
  virtual ~SessionObserver() = default;
  // A start, switch or boot session whose plugin is configured, before it is installed (on a
  // worker). Throwing refuses the request with the exception's message; a running plugin stays.
  virtual void session_configured(const std::string& robot_id, const PluginConfig& config) = 0;
  // The session ended: a stop request, or a failed request that left it without a plugin.
  virtual void session_ended(const std::string& robot_id) = 0;
};

}  // namespace locd::server
