#include "locd/sim/scenario.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "locd/sdk/plugin.hpp"
#include "locd/sdk/plugin_config.hpp"
#include "locd/sim/grid_world.hpp"
#include "locd/sim/world_differences.hpp"

namespace locd::sim {

namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& file, const std::string& what) {
  std::ifstream in(file);
  if (!in) throw ConfigError("cannot read " + what + " '" + file.string() + "'");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

Pose2 pose_of(const Params& p, const std::string& key, const Pose2& fallback) {
  const auto v = p.numbers(key, {fallback.x, fallback.y, fallback.theta}, 3);
  return {v[0], v[1], v[2]};
}

RobotSpec parse_robot(const Params& p) {
  p.expect_only({"id", "start", "max_speed", "max_yaw_rate", "max_acceleration", "lookahead", "waypoints",
                 "loop"});
  RobotSpec r;
  r.id = p.required_text("id");
  if (r.id.empty()) p.fail("id", "is empty; expected a robot name");
  r.start = pose_of(p, "start", {});
  r.max_speed = p.number("max_speed", r.max_speed, Range{0.0, 10.0, true, false});
  r.max_yaw_rate = p.number("max_yaw_rate", r.max_yaw_rate, Range{0.0, 10.0, true, false});
  r.max_acceleration = p.number("max_acceleration", r.max_acceleration, Range{0.0, 20.0, true, false});
  r.lookahead = p.number("lookahead", r.lookahead, Range{0.1, 10.0, false, false});
  r.loop = p.flag("loop", true);
  const YAML::Node list = p.node()["waypoints"];
  if (!list || !list.IsSequence() || list.size() < 2) {
    p.fail("waypoints", "needs a list of at least 2 points [[x, y], ...]");
  }
  for (size_t i = 0; i < list.size(); ++i) {
    const YAML::Node n = list[i];
    double x = 0, y = 0;
    if (!n.IsSequence() || n.size() != 2 || !YAML::convert<double>::decode(n[0], x) ||
        !YAML::convert<double>::decode(n[1], y) || !std::isfinite(x) || !std::isfinite(y)) {
      p.fail("waypoints", "entry " + std::to_string(i) + " is not a point [x, y] of two finite numbers");
    }
    if (!r.waypoints.empty() && (Eigen::Vector2d(x, y) - r.waypoints.back()).norm() < 1e-3) {
      p.fail("waypoints", "entry " + std::to_string(i) + " repeats the previous point");
    }
    r.waypoints.emplace_back(x, y);
  }
  return r;
}

}  // namespace

Scenario parse_scenario(const std::string& text, const std::string& source, const fs::path& base_directory) {
  const Params p = Params::parse(text, source);
  p.expect_only({"name", "seed", "duration_s", "map", "map_directories", "robot", "sensors", "localizer",
                 "evaluation", "kidnap", "differences"});
  Scenario s;
  s.file = source;
  s.name = p.required_text("name");
  s.seed = static_cast<uint64_t>(p.integer("seed", 1, 0, std::numeric_limits<long>::max()));
  s.duration_s = p.number("duration_s", s.duration_s, Range{0.0, 86400.0, true, false});

  s.map_name = p.required_text("map");
  std::vector<std::string> directories{"../maps"};
  if (p.has("map_directories")) {
    const YAML::Node list = p.node()["map_directories"];
    if (!list.IsSequence() || list.size() == 0) p.fail("map_directories", "is not a non-empty list of directories");
    directories.clear();
    for (size_t i = 0; i < list.size(); ++i) {
      if (!list[i].IsScalar()) p.fail("map_directories", "entry " + std::to_string(i) + " is not a directory name");
      directories.push_back(list[i].Scalar());
    }
  }
  for (const auto& d : directories) {
    const fs::path dir(d);
    s.map_directories.push_back(dir.is_absolute() ? dir : base_directory / dir);
  }
  try {
    s.map_file = MapResolver(s.map_directories).resolve(s.map_name);
  } catch (const ConfigError& e) {
    p.fail("map", std::string("cannot be used: ") + e.what());
  }
  if (is_occupancy_map_yaml(s.map_file)) {
    // A map_server map: its image resolves next to the YAML, in the map directories as well.
    const fs::path folder = fs::path(s.map_name).parent_path();
    const MapResolver resolver(s.map_directories);
    try {
      s.world = std::make_shared<GridWorld>(std::make_shared<OccupancyMap>(load_occupancy_map(
          s.map_file, [&](const std::string& image) { return resolver.resolve((folder / image).lexically_normal().string()); },
          Limits{}.max_map_cells)));
    } catch (const ConfigError& e) {
      p.fail("map", std::string("cannot be used: ") + e.what());
    }
  } else {
    s.map = load_feature_map(s.map_file.string(), 100000);
    s.world = std::make_shared<SegmentWorld>(SegmentWorld::from_feature_map(s.map));
  }

  if (p.has("differences")) {
    s.world = std::make_shared<DifferentWorld>(s.world, parse_world_differences(p.child("differences")));
  }

  if (!p.has("robot")) p.fail("robot", "is missing; expected {id, start, waypoints, ...}");
  s.robot = parse_robot(p.child("robot"));
  if (!p.has("sensors")) p.fail("sensors", "is missing; expected a map of sensors (laser, odometry)");
  s.sensors = p.child("sensors");

  if (!p.has("localizer")) p.fail("localizer", "is missing; expected {config_file, initial_pose_offset, initial_stddev}");
  const Params loc = p.child("localizer");
  loc.expect_only({"config_file", "initial_pose_offset", "initial_stddev", "wrong_start"});
  const fs::path config_file(loc.required_text("config_file"));
  s.localizer.config_file = config_file.is_absolute() ? config_file : base_directory / config_file;
  try {
    s.localizer.config_text = read_text(s.localizer.config_file, "localizer config");
  } catch (const ConfigError& e) {
    loc.fail("config_file", std::string("cannot be used: ") + e.what());
  }
  PluginConfig plugin;
  try {
    plugin = split_plugin_config(s.localizer.config_text, s.localizer.config_file.string());
  } catch (const ConfigError& e) {
    loc.fail("config_file", "= '" + s.localizer.config_file.string() + "' is not a valid plugin config: " + e.what());
  }
  s.localizer.plugin = plugin.plugin;
  s.localizer.params = plugin.params;
  s.localizer.initial_pose_offset = pose_of(loc, "initial_pose_offset", {});
  const auto stddev = loc.numbers("initial_stddev", {0.5, 0.5, 0.1}, 3, Range::positive());
  s.localizer.initial_stddev = Eigen::Vector3d(stddev[0], stddev[1], stddev[2]);

  if (loc.has("wrong_start")) {
    if (loc.has("initial_pose_offset")) {
      loc.fail("wrong_start", "and initial_pose_offset exclude each other (a wrong start draws the pose the plugin gets)");
    }
    const Params wrong = loc.child("wrong_start");
    wrong.expect_only({"min_distance_m"});
    s.localizer.wrong_start_min_distance_m = wrong.number("min_distance_m", 10.0, Range{0.0, 1e5, false, true});
  }
  if (p.has("kidnap")) {
    const Params k = p.child("kidnap");
    k.expect_only({"at_s", "to", "min_distance_m"});
    KidnapSpec kidnap;
    if (!k.has("at_s")) k.fail("at_s", "is missing; expected the time of the kidnap in s");
    kidnap.at_s = k.number("at_s", 0.0, Range{0.0, s.duration_s, false, false});
    if (k.has("to") && k.has("min_distance_m")) k.fail("to", "and min_distance_m exclude each other");
    if (k.has("to")) kidnap.to = pose_of(k, "to", {});
    kidnap.min_distance_m = k.number("min_distance_m", kidnap.min_distance_m, Range{0.0, 1e5, false, true});
    s.kidnap = kidnap;
    if (s.localizer.wrong_start_min_distance_m) {
      k.fail("at_s", "a kidnap and localizer.wrong_start exclude each other (one event per run is scored)");
    }
  }

  const Params evaluation = p.child("evaluation");
  evaluation.expect_only({"convergence_threshold_m", "detection_deadline_s", "relocalization_deadline_s"});
  s.convergence_threshold_m = evaluation.number("convergence_threshold_m", 0.2, Range::positive());
  s.evaluation.convergence_threshold_m = s.convergence_threshold_m;
  s.evaluation.detection_deadline_s = evaluation.number("detection_deadline_s", 5.0, Range::positive());
  s.evaluation.relocalization_deadline_s = evaluation.number("relocalization_deadline_s", 10.0, Range::positive());
  return s;
}

Scenario load_scenario(const fs::path& file) {
  const std::string text = read_text(file, "scenario");
  fs::path base = file.parent_path();
  if (base.empty()) base = ".";
  return parse_scenario(text, file.string(), base);
}

}  // namespace locd::sim
