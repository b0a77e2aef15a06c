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
//   localizer: {config_file, initial_pose_offset: [dx, dy, dyaw], initial_stddev: [sx, sy, syaw],
//               wrong_start: {min_distance_m: 15}}   # optional, instead of initial_pose_offset
//   kidnap: {at_s: 40, min_distance_m: 10}           # optional; or {at_s: 40, to: [x, y, yaw]}
//   evaluation: {convergence_threshold_m: 0.2, detection_deadline_s: 5, relocalization_deadline_s: 10}
//   differences: {map_transform, clutter, people, walls, doors, glass}   # optional: the world is not
//                                                    #   its map (world_differences.hpp)
//
// A wrong start gives the plugin a pose on the route (a point of the waypoint polyline, heading
// along it) at least min_distance_m from the true start, drawn from the run's seed, with the
// configured initial_stddev: the plugin believes it. A kidnap carries the robot at at_s to `to`,
// or to a pose on the route drawn from the seed at least min_distance_m from where it is; its
// odometry does not see the jump, its other sensors see the new place.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
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
  std::optional<double> wrong_start_min_distance_m;  // set: a wrong start (see above)
};

struct KidnapSpec {
  double at_s = 0.0;
  std::optional<Pose2> to;      // where to; else a random pose on the route...
  double min_distance_m = 10.0;  // ...at least this far from the robot
};

// What locsim checks a run against (the targets are the defaults).
struct EvaluationSpec {
  double convergence_threshold_m = 0.2;     // error below it: converged, and "small" for false alarms
  double detection_deadline_s = 5.0;        // a kidnap or wrong start must be reported within it
  double relocalization_deadline_s = 10.0;  // and the error be back under the threshold within it
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
  std::optional<KidnapSpec> kidnap;
  double convergence_threshold_m = 0.2;
  EvaluationSpec evaluation;  // evaluation.convergence_threshold_m == convergence_threshold_m
};

// Relative paths in the text are resolved against base_directory.
Scenario parse_scenario(const std::string& text, const std::string& source,
                        const std::filesystem::path& base_directory);
Scenario load_scenario(const std::filesystem::path& file);

}  // namespace locd::sim
