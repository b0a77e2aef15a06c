// The daemon's own config (config/locd.yaml documents every key). Parsed with locd::Params:
// every bad key or value is a ConfigError naming the key, where it stands and what is allowed.
// Relative directories and files resolve against the config file's folder.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "locd/sdk/plugin.hpp"
#include "locd/sdk/plugin_config.hpp"
#include "locd/server/plugin_workers.hpp"
#include "locd/server/request_limiter.hpp"

namespace locd::server {

// A session started at boot, so the server runs with no client at all.
struct BootSession {
  std::string robot_id;
  PluginConfig config;                       // plugin name and its params
  PluginConfigText text;                     // the same as text, for the plugin's worker process
  std::string source;                        // where the config came from, for messages
  std::optional<std::array<double, 3>> initial_pose;  // x, y, yaw
};

struct ServerConfig {
  std::string server_id;  // default "<hostname>-<pid>"
  int domain_id = 0;
  std::vector<std::filesystem::path> plugin_directories;
  std::vector<std::filesystem::path> map_directories;
  std::filesystem::path output_directory;  // where plugins may write (saved maps); empty = nowhere
  int workers = 2;  // threads for the server's own work (requests, statuses); plugins run in worker processes
  int queue_depth = 64;
  size_t max_sessions = 256;  // robots served at once; requests beyond are refused
  double status_period_s = 1.0;
  // A session a remote request started ends this long after no live writer of its robot's
  // requests or sensor data remains (session ownership); boot sessions are the server's own.
  double session_grace_s = 10.0;
  Limits limits;
  RequestLimits request_limits;  // per robot: session requests, initial poses, map saves
  LogLevel log_level = LogLevel::kInfo;
  std::vector<BootSession> sessions;
  WorkerSettings plugin_workers;            // how plugins run: worker processes, deadlines, memory
  FailurePolicy failures;                   // restarts of failed plugins
  std::filesystem::path state_directory;    // where sessions' resume states survive a restart; empty = nowhere
  double weight = 1.0;                      // share of the fleet's robots this server takes
  std::string server_group;                 // robots with `server_group: NAME` go to servers of that group

  // `base_directory` anchors relative paths (the config file's folder).
  static ServerConfig parse(const std::string& yaml_text, const std::string& source_name,
                            const std::filesystem::path& base_directory);
  static ServerConfig load_file(const std::filesystem::path& file);
};

std::string default_server_id();
// locd-worker next to the running executable.
std::filesystem::path default_worker_executable();

// The config's worker settings with what workers may read (plugin and map directories) and write
// (the output directory); and the same for the inspectors that read the plugins' catalog.
WorkerSettings worker_settings(const ServerConfig& config);
InspectorSettings inspector_settings(const ServerConfig& config);

}  // namespace locd::server
