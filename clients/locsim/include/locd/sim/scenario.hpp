// A scenario: the world (a feature map of walls, or a map_server occupancy grid), one robot
// following waypoints, its sensors and the localizer it runs. Parsed with locd::Params, so every error names the key, where it stands and
// what is allowed.
//
//   name: corridor
//   seed: 7
//   duration_s: 120
//   map: corridor.yaml            # resolved in map_directories (default ["../maps"], relative
//   map_directories: ["../maps"]  #   to the scenario file)
//   robot: {id, start: [x, y, yaw], max_speed, max_yaw_rate, max_acceleration, lookahead,
//           waypoints: [[x, y], ...], loop: true}
//   sensors: {laser: {...}, odometry: {...}}      # each parsed by its sensor model
//   localizer: {config_file, initial_pose_offset: [dx, dy, dyaw], initial_stddev: [sx, sy, syaw]}
//   evaluation: {convergence_threshold_m: 0.2}
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "locd/sdk/feature_map.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sdk/params.hpp"

namespace locd::sim {

class RangeWorld;

struct RobotSpec {
  std::string id = "robot";
  Pose2 start;
  double max_speed = 1.0;          // m/s
  double max_yaw_rate = 0.8;       // rad/s
  double max_acceleration = 0.5;   // m/s^2
  double lookahead = 1.0;          // m, pure-pursuit look-ahead distance
  std::vector<Eigen::Vector2d> waypoints;
  bool loop = true;
};

struct LocalizerSpec {
  std::filesystem::path config_file;
  std::string config_text;     // the plugin config (plugin + params), as sent to a server
  std::string plugin;          // its `plugin`
  Params params;               // its `params`, rooted at the plugin's name
  Pose2 initial_pose_offset;   // error of the pose given to the plugin at start (map frame)
  Eigen::Vector3d initial_stddev{0.5, 0.5, 0.1};
};

struct Scenario {
  std::filesystem::path file;
  std::string name;
  uint64_t seed = 1;
  double duration_s = 60.0;
  std::string map_name;
  std::vector<std::filesystem::path> map_directories;
  std::filesystem::path map_file;
  FeatureMap2D map;                         // walls of a feature map (empty for a grid world)
  std::shared_ptr<const RangeWorld> world;  // what the laser sees: the walls or the grid
  RobotSpec robot;
  Params sensors;  // one child per sensor, validated by the sensor models
  LocalizerSpec localizer;
  double convergence_threshold_m = 0.2;
};

// Relative paths in the text are resolved against base_directory.
Scenario parse_scenario(const std::string& text, const std::string& source,
                        const std::filesystem::path& base_directory);
Scenario load_scenario(const std::filesystem::path& file);

}  // namespace locd::sim
