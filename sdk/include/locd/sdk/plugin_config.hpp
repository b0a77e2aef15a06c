// A robot's localizer config (a file for `locctl use`, SessionRequest.config_yaml, a scenario's
// localizer, a server boot session):
//
//   plugin: feature_ekf        # which localizer (a name, never a path)
//   params:                    # the plugin's own parameters, validated by its configure()
//     map: corridor.yaml
//   ros2:                      # optional: ROS 2 topics for the robot (ros2_config.hpp)
//     namespace: /robot1
//     topics: {scan: scan, odometry: odom, pose: amcl_pose}
//
// A Nav2 params file is one too (README "A Nav2 params file"): `amcl: {ros__parameters: ...}` is
// grid_mcl with AMCL's parameters, its ROS keys (frames, scan_topic, tf_broadcast,
// transform_tolerance) the robot's ros2 section, map_server's yaml_filename the map:
//
//   amcl:
//     ros__parameters: {alpha1: 0.2, base_frame_id: base_footprint, max_particles: 2000, ...}
//   map_server:
//     ros__parameters: {yaml_filename: warehouse.yaml}
//   ros2: {namespace: /robot1}     # optional, as above
//
// split_plugin_config checks the frame (known keys, a valid plugin name, params a map) and hands
// back the plugin name and its parameters, rooted at the plugin's name, so a plugin's errors read
// "parameter 'feature_ekf.gate_probability' (line 4, column 21) = 1.5 is out of range; ...".
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "locd/sdk/params.hpp"
#include "locd/sdk/ros2_config.hpp"

namespace locd {

struct PluginConfig {
  std::string plugin;
  Params params;
  std::optional<Ros2Config> ros2;  // the `ros2:` section, when present
  // `server_group: NAME`: only the servers of that group (their config's server_group) serve
  // the robot; empty: any server.
  std::string server_group;
};

// A plugin config as text, so that it can travel to the worker process that runs the plugin and
// be parsed there with the same line and column numbers in every message: `yaml` is the whole
// document it stands in, `path` the keys leading to it inside (empty for a robot's config file or
// a session request; {"sessions", "2", "config"} for a config inline in the server's own).
struct PluginConfigText {
  std::string yaml;
  std::string source;
  std::vector<std::string> path;
};

// Throws ConfigError unless `name` matches [a-z][a-z0-9_]{0,63}; a name with '/' or '.' gets
// "plugin must be a name, not a path". `what` prefixes the message (e.g. "session request").
void check_plugin_name(const std::string& name, const std::string& what);

// Parses YAML text (malformed YAML -> ConfigError with source, line and column).
PluginConfig split_plugin_config(const std::string& yaml_text, const std::string& source_name);
// Same for a document already parsed (e.g. an inline map inside the server's config).
PluginConfig split_plugin_config(const Params& document, const std::string& source_name);
// Same for a config given as text and a path inside it.
PluginConfig split_plugin_config(const PluginConfigText& text);

}  // namespace locd
