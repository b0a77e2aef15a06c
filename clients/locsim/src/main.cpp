// locsim: simulated robots for locd. `run` drives a scenario offline straight through a plugin;
// `live` publishes it in real time to a running locd over DDS; `montecarlo` runs many seeded
// drives. The command line (CLI11) becomes a Command; the scenario's kind (scenario_kinds.hpp)
// runs it.
#include <CLI/CLI.hpp>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "locd/sdk/ros2_config.hpp"
#include "fleet.hpp"
#include "replay.hpp"
#include "scenario_kinds.hpp"

namespace fs = std::filesystem;
using locd::sim::Command;
using locd::sim::UsageError;
using locd::sim::ReplayOptions;

namespace {

const char* kUsage =
    "usage:\n"
    "  locsim run SCENARIO.yaml [--json] [--plot FILE.png] [--plugin-dir DIR] [--seed N] [--duration S]\n"
    "                  [--mcap OUT.mcap] [--rawlog FILE.rawlog] [--trace FILE.csv]\n"
    "      offline: the scenario straight through the plugin, no DDS; --mcap records the run (sensors,\n"
    "      poses, ground truth) for Foxglove and locsim replay; --rawlog also writes the run as an MRPT\n"
    "      rawlog (laser scenarios; needs carmen2rawlog from mrpt-apps); --trace: every estimate with its\n"
    "      covariance, NEES and localization state as CSV\n"
    "  locsim live SCENARIO.yaml [--domain N] [--rate X] [--duration S] [--seed N] [--json] [--plot FILE.png]\n"
    "              [--server-timeout S] [--ros2 NAMESPACE]\n"
    "      real time against a running locd (DDS through CYCLONEDDS_URI); --rate 2 runs twice as fast;\n"
    "      waits --server-timeout seconds (default 10) for the server and each answer; --ros2: the robot\n"
    "      speaks ROS 2 in NAMESPACE (LaserScan, Odometry out; PoseWithCovarianceStamped amcl_pose in)\n"
    "  locsim montecarlo SCENARIO.yaml [--runs N] [--strategies a,b,...] [--json] [--plot FILE.png]\n"
    "                   [--plugin-dir DIR] [--seed N] [--duration S]\n"
    "      a road-sign scenario (feature_ekf landmarks), N seeded drives per association strategy\n"
    "      (default: known_id, nearest_neighbor, jcbb, pda) side by side: CEP50/CEP95, wrong associations;\n"
    "      a segment-world scenario (corridor, ceiling hall, grid worlds): seeds N..N+runs-1 (default from 1)\n"
    "      pooled: consistency, false alarms, kidnap / wrong-start detection and relocalization rates\n"
    "  locsim replay IN.mcap [--domain N] [--rate X | --fast] [--robot R]... [--server-timeout S] [--json]\n"
    "  locsim replay IN.mcap --offline [--plugin-dir DIR] [--map-dir DIR] [--rate X] [--robot R]... [--json]\n"
    "      a recording (locctl record, locsim run --mcap) fed again: into a running locd (default real time),\n"
    "      or --offline through the plugin its session request names (default as fast as possible);\n"
    "      compares the poses with the recorded ones. Maps: --map-dir, default config/maps\n"
    "  locsim replay BAG.mcap --config ROBOT.yaml [--topics MAP.yaml] [--topic KEY=NAME]... [--base-frame F]\n"
    "                [--initial-pose X,Y,YAW | --initial-pose reference [--initial-offset DX,DY,DYAW]]\n"
    "                [--reference REF.tum] [--robot R]\n"
    "                [--offline | --domain N] [--rate X | --fast] [--json]\n"
    "      a ROS 2 bag (ros2 bag record -s mcap) as robot R (default robot1) with the plugin config ROBOT.yaml;\n"
    "      topics from MAP.yaml's or ROBOT.yaml's ros2: section or AMCL's (/scan, /odom, /tf, /tf_static),\n"
    "      KEY one of scan cloud image imu odometry tf tf_static; --reference: APE, RPE against a TUM trajectory\n"
    "  locsim fleet SCENARIO.yaml --robots N [--domain N] [--rate X] [--duration S] [--seed N]\n"
    "               [--distinct K] [--server-pid PID]... [--server-timeout S] [--json] [--plot FILE.png]\n"
    "               [--outage-report]\n"
    "      N simulated robots (K distinct runs of a laser/odometry scenario, each robot its own id and\n"
    "      clock) against running locd servers: poses per second, latency p50/p99/max, what the servers\n"
    "      lost, dropped or rejected, and with --server-pid the servers' CPU and memory (workers included);\n"
    "      --outage-report: per robot, when its longest wait for a pose ended and its error then\n"
    "  Segment worlds, run / live / montecarlo: --kidnap-at S [--kidnap-distance M] carries the robot at S\n"
    "      to a route pose >= M m away (default 10; its odometry does not see it); --wrong-start M starts\n"
    "      the plugin from a route pose >= M m off. Either replaces the scenario's kidnap / start.\n"
    "  locsim --help\n"
    "Plugin directory for run: --plugin-dir, else $LOCD_PLUGIN_DIR, else <locsim's dir>/../plugins.\n";

// Numbers are read as text by CLI11 and converted here, so every message names the option, the
// value and the allowed range.
double parse_number(const std::string& option, const std::string& text, double min, double max) {
  try {
    size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size() && v >= min && v <= max) return v;
  } catch (const std::exception&) {
  }
  throw UsageError(option + " " + text + ": expected a number in [" + std::to_string(min) + ", " +
                   std::to_string(max) + "]");
}

uint64_t parse_unsigned(const std::string& option, const std::string& text, uint64_t max) {
  try {
    size_t used = 0;
    const unsigned long long v = std::stoull(text, &used);
    if (used == text.size() && text[0] != '-' && v <= max) return v;
  } catch (const std::exception&) {
  }
  throw UsageError(option + " " + text + ": expected an integer in [0, " + std::to_string(max) + "]");
}

// A ROS 2 namespace: checked as the server will check it (locd/sdk/ros2_config.hpp), "/robot1".
std::string parse_ros2_namespace(const std::string& text) {
  std::string ros_namespace;
  try {
    ros_namespace =
        locd::parse_ros2_config(locd::Params::parse("namespace: '" + text + "'\ntopics: {scan: scan}\n", "--ros2")).ros_namespace;
  } catch (const std::exception&) {
  }
  if (ros_namespace.empty()) {
    throw UsageError("--ros2 " + text + ": expected a ROS 2 namespace such as /robot1 (names of [A-Za-z0-9_], not "
                     "starting with a digit, joined by '/')");
  }
  return ros_namespace;
}

fs::path default_plugin_directory() {
  if (const char* env = std::getenv("LOCD_PLUGIN_DIR"); env && *env) return env;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return "plugins";
  return self.parent_path() / ".." / "plugins";
}

// The options as text, before conversion.
struct Text {
  std::string scenario, seed, duration, runs, strategies, domain, server_timeout, rate, ros2;
  std::string kidnap_at, kidnap_distance, wrong_start;
  std::vector<std::string> plugin_directories;
};

ReplayOptions parse_replay(const std::vector<std::string>& args) {
  ReplayOptions o;
  std::string domain, rate, server_timeout;
  bool fast = false;
  std::vector<std::string> plugin_directories, map_directories;
  CLI::App app{"locsim replay", "locsim replay"};
  app.set_help_flag();
  app.add_option("file", o.file, "IN.mcap");
  app.add_flag("--json", o.json);
  app.add_flag("--offline", o.offline);
  app.add_flag("--fast", fast);
  app.add_option("--domain", domain);
  app.add_option("--rate", rate);
  app.add_option("--server-timeout", server_timeout);
  app.add_option("--robot", o.robots)->expected(1)->take_all();
  app.add_option("--plugin-dir", plugin_directories)->expected(1)->take_all();
  app.add_option("--map-dir", map_directories)->expected(1)->take_all();
  app.add_option("--config", o.config_file);
  app.add_option("--topics", o.topics_file);
  app.add_option("--topic", o.topic_overrides)->expected(1)->take_all();
  app.add_option("--base-frame", o.base_frame);
  app.add_option("--initial-pose", o.initial_pose);
  app.add_option("--initial-offset", o.initial_offset);
  app.add_option("--reference", o.reference_file);
  std::vector<std::string> rest(args.rbegin(), args.rend() - 1);
  try {
    app.parse(rest);
  } catch (const CLI::ParseError& e) {
    throw UsageError(std::string(e.what()) + " (locsim replay)");
  }
  if (o.config_file.empty() && (!o.topics_file.empty() || !o.topic_overrides.empty() || !o.base_frame.empty() ||
                                !o.initial_pose.empty() || !o.initial_offset.empty() || !o.reference_file.empty())) {
    throw UsageError("--topics, --topic, --base-frame, --initial-pose, --initial-offset and --reference replay a ROS 2 bag: give its "
                     "plugin config with --config");
  }
  if (o.file.empty()) throw UsageError("locsim replay needs an IN.mcap");
  if (fast && !rate.empty()) throw UsageError("--fast and --rate exclude each other");
  if (fast) o.rate = 0.0;
  if (!rate.empty()) o.rate = parse_number("--rate", rate, 0.01, 1000.0);
  if (!domain.empty()) o.domain_id = static_cast<uint32_t>(parse_unsigned("--domain", domain, 232));
  if (!server_timeout.empty()) o.server_timeout_s = parse_number("--server-timeout", server_timeout, 0.1, 3600.0);
  for (const auto& d : plugin_directories) o.plugin_directories.push_back(d);
  if (o.plugin_directories.empty()) o.plugin_directories.push_back(default_plugin_directory());
  for (const auto& d : map_directories) o.map_directories.push_back(d);
  if (o.map_directories.empty()) o.map_directories.push_back("config/maps");
  if (!o.offline && (!plugin_directories.empty() || !map_directories.empty())) {
    throw UsageError("--plugin-dir and --map-dir apply to --offline only (a running locd has its own)");
  }
  return o;
}

struct FleetCommand {
  std::filesystem::path scenario_file;
  locd::sim::FleetOptions options;
};

FleetCommand parse_fleet(const std::vector<std::string>& args) {
  FleetCommand c;
  std::string scenario, robots, domain, rate, duration, seed, distinct, server_timeout;
  std::vector<std::string> server_pids;
  CLI::App app{"locsim fleet", "locsim fleet"};
  app.set_help_flag();
  app.add_option("scenario", scenario, "SCENARIO.yaml");
  app.add_flag("--json", c.options.json);
  app.add_flag("--outage-report", c.options.outage_report);
  app.add_option("--plot", c.options.plot_file);
  app.add_option("--robots", robots);
  app.add_option("--domain", domain);
  app.add_option("--rate", rate);
  app.add_option("--duration", duration);
  app.add_option("--seed", seed);
  app.add_option("--distinct", distinct);
  app.add_option("--server-timeout", server_timeout);
  app.add_option("--server-pid", server_pids)->expected(1)->take_all();
  std::vector<std::string> rest(args.rbegin(), args.rend() - 1);
  try {
    app.parse(rest);
  } catch (const CLI::ParseError& e) {
    throw UsageError(std::string(e.what()) + " (locsim fleet)");
  }
  if (scenario.empty()) throw UsageError("locsim fleet needs a SCENARIO.yaml");
  if (robots.empty()) throw UsageError("locsim fleet needs --robots N");
  c.scenario_file = scenario;
  c.options.robots = parse_unsigned("--robots", robots, 100000);
  if (c.options.robots == 0) throw UsageError("--robots 0: expected an integer in [1, 100000]");
  if (!domain.empty()) c.options.domain_id = static_cast<uint32_t>(parse_unsigned("--domain", domain, 232));
  if (!rate.empty()) c.options.rate = parse_number("--rate", rate, 0.01, 100.0);
  if (!duration.empty()) c.options.duration_s = parse_number("--duration", duration, 1e-3, 86400.0);
  if (!seed.empty()) c.options.seed = parse_unsigned("--seed", seed, std::numeric_limits<long>::max());
  if (!distinct.empty()) c.options.distinct_runs = parse_unsigned("--distinct", distinct, 1000);
  if (!server_timeout.empty()) c.options.server_timeout_s = parse_number("--server-timeout", server_timeout, 0.1, 3600.0);
  for (const auto& pid : server_pids) {
    c.options.server_pids.push_back(static_cast<pid_t>(parse_unsigned("--server-pid", pid, 1u << 30)));
  }
  return c;
}

Command parse(const std::vector<std::string>& args) {
  const std::string mode = args[0];
  if (mode != "run" && mode != "live" && mode != "montecarlo") {
    throw UsageError("unknown command '" + mode + "'; known: run, live, montecarlo, replay, fleet");
  }
  Command c;
  c.mode = mode;
  Text text;
  CLI::App app{"locsim", "locsim"};
  app.set_help_flag();
  app.add_option("scenario", text.scenario, "SCENARIO.yaml");
  app.add_flag("--json", c.json);
  app.add_option("--plot", c.plot_file);
  app.add_option("--seed", text.seed);
  app.add_option("--duration", text.duration);
  app.add_option("--kidnap-at", text.kidnap_at);
  app.add_option("--kidnap-distance", text.kidnap_distance);
  app.add_option("--wrong-start", text.wrong_start);
  if (mode == "run" || mode == "montecarlo") {
    app.add_option("--plugin-dir", text.plugin_directories)->expected(1)->take_all();
  }
  if (mode == "run") {
    app.add_option("--mcap", c.mcap_file);
    app.add_option("--rawlog", c.rawlog_file);
    app.add_option("--trace", c.trace_file);
  }
  if (mode == "live") {
    app.add_option("--domain", text.domain);
    app.add_option("--server-timeout", text.server_timeout);
    app.add_option("--rate", text.rate);
    app.add_option("--ros2", text.ros2);
  }
  if (mode == "montecarlo") {
    app.add_option("--runs", text.runs);
    app.add_option("--strategies", text.strategies);
  }
  std::vector<std::string> rest(args.rbegin(), args.rend() - 1);  // CLI11 takes them last first
  try {
    app.parse(rest);
  } catch (const CLI::ParseError& e) {
    throw UsageError(std::string(e.what()) + " (locsim " + mode + ")");
  }
  if (!text.seed.empty()) c.seed = parse_unsigned("--seed", text.seed, std::numeric_limits<long>::max());
  if (!text.duration.empty()) c.duration_s = parse_number("--duration", text.duration, 1e-3, 86400.0);
  if (!text.kidnap_at.empty()) c.kidnap_at_s = parse_number("--kidnap-at", text.kidnap_at, 0.0, 86400.0);
  if (!text.kidnap_distance.empty()) {
    c.kidnap_distance_m = parse_number("--kidnap-distance", text.kidnap_distance, 0.0, 1e5);
  }
  if (!text.wrong_start.empty()) c.wrong_start_m = parse_number("--wrong-start", text.wrong_start, 0.0, 1e5);
  if (!text.runs.empty()) c.runs = static_cast<int>(parse_unsigned("--runs", text.runs, 100000));
  if (!text.strategies.empty()) {
    c.strategies.clear();
    std::stringstream list(text.strategies);
    for (std::string name; std::getline(list, name, ',');) c.strategies.push_back(name);
  }
  if (!text.domain.empty()) c.live.domain_id = static_cast<uint32_t>(parse_unsigned("--domain", text.domain, 232));
  if (!text.server_timeout.empty()) {
    c.live.server_timeout_s = parse_number("--server-timeout", text.server_timeout, 0.1, 3600.0);
  }
  if (!text.rate.empty()) c.live.rate = parse_number("--rate", text.rate, 0.01, 100.0);
  if (!text.ros2.empty()) c.live.ros2_namespace = parse_ros2_namespace(text.ros2);
  for (const std::string& d : text.plugin_directories) c.plugin_directories.push_back(d);
  if (c.plugin_directories.empty()) c.plugin_directories.push_back(default_plugin_directory());
  if (text.scenario.empty()) throw UsageError("locsim " + mode + " needs a SCENARIO.yaml");
  c.scenario_file = text.scenario;
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) {
    std::cerr << kUsage;
    return 2;
  }
  for (const std::string& a : args) {
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    }
  }
  try {
    if (args[0] == "replay") return locd::sim::run_replay(parse_replay(args));
    if (args[0] == "fleet") {
      const FleetCommand fleet = parse_fleet(args);
      return locd::sim::run_fleet(locd::sim::load_scenario(fleet.scenario_file), fleet.options);
    }
    return locd::sim::run_command(parse(args));
  } catch (const UsageError& e) {
    std::cerr << "locsim: " << e.what() << "\n" << kUsage;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "locsim: " << e.what() << "\n";
    return 1;
  }
}
