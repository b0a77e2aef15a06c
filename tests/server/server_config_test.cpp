// The server config: defaults, relative paths against the config's folder, boot sessions, and
// a message naming key and allowed range for each bad key or value.
#include <gtest/gtest.h>

#include <fstream>

#include "locd/server/server_config.hpp"

namespace {

namespace fs = std::filesystem;
using locd::ConfigError;
using locd::server::ServerConfig;

const fs::path kBase = "/srv/locd/config";

std::string error_of(const std::string& yaml) {
  try {
    ServerConfig::parse(yaml, "test.yaml", kBase);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

void expect_error(const std::string& yaml, const std::vector<std::string>& parts) {
  const std::string what = error_of(yaml);
  for (const auto& part : parts) EXPECT_NE(what.find(part), std::string::npos) << "'" << part << "' not in: " << what;
}

TEST(ServerConfig, DefaultsForAnEmptyConfig) {
  const auto c = ServerConfig::parse("", "empty.yaml", kBase);
  EXPECT_EQ(c.domain_id, 0);
  EXPECT_EQ(c.workers, 2);
  EXPECT_EQ(c.queue_depth, 64);
  EXPECT_DOUBLE_EQ(c.status_period_s, 1.0);
  EXPECT_DOUBLE_EQ(c.session_grace_s, 10.0);
  EXPECT_EQ(c.limits.max_scan_beams, locd::Limits{}.max_scan_beams);
  EXPECT_EQ(c.log_level, locd::LogLevel::kInfo);
  EXPECT_FALSE(c.server_id.empty());
  EXPECT_NE(c.server_id.find('-'), std::string::npos);  // <hostname>-<pid>
  EXPECT_TRUE(c.sessions.empty());
}

TEST(ServerConfig, ParsesEveryKeyAndResolvesRelativeDirectories) {
  const auto c = ServerConfig::parse(R"(
server_id: lab-1
domain_id: 42
plugin_directories: [../build/plugins, /opt/locd/plugins]
map_directories: [maps]
workers: 4
queue_depth: 16
status_period_s: 0.5
limits: {max_scan_beams: 720, max_cloud_points: 1000, max_image_pixels: 640000, max_detections: 10,
         max_particles: 5000, max_map_cells: 100000}
log_level: debug
)", "full.yaml", kBase);
  EXPECT_EQ(c.server_id, "lab-1");
  EXPECT_EQ(c.domain_id, 42);
  ASSERT_EQ(c.plugin_directories.size(), 2u);
  EXPECT_EQ(c.plugin_directories[0], fs::path("/srv/locd/build/plugins"));
  EXPECT_EQ(c.plugin_directories[1], fs::path("/opt/locd/plugins"));
  ASSERT_EQ(c.map_directories.size(), 1u);
  EXPECT_EQ(c.map_directories[0], fs::path("/srv/locd/config/maps"));
  EXPECT_EQ(c.workers, 4);
  EXPECT_EQ(c.queue_depth, 16);
  EXPECT_DOUBLE_EQ(c.status_period_s, 0.5);
  EXPECT_EQ(c.limits.max_scan_beams, 720u);
  EXPECT_EQ(c.limits.max_cloud_points, 1000u);
  EXPECT_EQ(c.limits.max_image_pixels, 640000u);
  EXPECT_EQ(c.limits.max_detections, 10u);
  EXPECT_EQ(c.limits.max_particles, 5000u);
  EXPECT_EQ(c.limits.max_map_cells, 100000u);
  EXPECT_EQ(c.log_level, locd::LogLevel::kDebug);
}

TEST(ServerConfig, EachBadValueNamesKeyAndAllowedRange) {
  expect_error("domain_id: 300", {"'domain_id'", "300", "allowed: [0, 232]"});
  expect_error("domain_id: -1", {"'domain_id'", "allowed: [0, 232]"});
  expect_error("workers: 0", {"'workers'", "allowed: [1, 64]"});
  expect_error("workers: 65", {"'workers'", "allowed: [1, 64]"});
  expect_error("queue_depth: 10001", {"'queue_depth'", "allowed: [1, 10000]"});
  expect_error("queue_depth: many", {"'queue_depth'", "'many' is not an integer", "[1, 10000]"});
  expect_error("status_period_s: 0", {"'status_period_s'", "allowed: [0.05, 3600]"});
  expect_error("session_grace_s: 0", {"'session_grace_s'", "allowed: [0.1, 86400]"});
  EXPECT_DOUBLE_EQ(ServerConfig::parse("session_grace_s: 2.5", "t.yaml", kBase).session_grace_s, 2.5);
  expect_error("log_level: loud", {"'log_level'", "'loud'", "allowed: debug, info, warning, error"});
  expect_error("limits: {max_scan_beams: 0}", {"'limits.max_scan_beams'", "allowed: [1, 65536]"});
  expect_error("limits: {max_scan_beams: 70000}", {"'limits.max_scan_beams'", "70000", "allowed: [1, 65536]"});
  expect_error("limits: {max_detections: 5000}", {"'limits.max_detections'", "allowed: [1, 4096]"});
  expect_error("plugin_directories: build/plugins", {"'plugin_directories'", "is not a list"});
  expect_error("server_id: ''", {"'server_id'", "1 to 64 characters"});
  expect_error("plugin_workers: {liveness_timeout_s: -1}", {"'plugin_workers.liveness_timeout_s'", "allowed: [0, 86400]"});
  EXPECT_DOUBLE_EQ(ServerConfig::parse("", "t.yaml", kBase).plugin_workers.liveness_timeout_s, 0.7);
  expect_error("plugin_workers: {sessions_per_worker: many}",
               {"'plugin_workers.sessions_per_worker'", "'many'", "allowed: auto or 1..100000"});
  expect_error("plugin_workers: {sessions_per_worker: 0}", {"'plugin_workers.sessions_per_worker'", "[1, 100000]"});
  expect_error("plugin_workers: {workers_per_plugin: -1}", {"'plugin_workers.workers_per_plugin'", "[0, 10000]"});
  const auto parse = [](const std::string& yaml) { return ServerConfig::parse(yaml, "t.yaml", kBase).plugin_workers; };
  EXPECT_EQ(parse("").sessions_per_worker, locd::server::WorkerSettings::kAuto);
  EXPECT_EQ(parse("plugin_workers: {sessions_per_worker: auto}").sessions_per_worker, locd::server::WorkerSettings::kAuto);
  EXPECT_EQ(parse("plugin_workers: {sessions_per_worker: 50}").sessions_per_worker, 50u);
  EXPECT_EQ(parse("plugin_workers: {sessions_per_worker: 1, plugins: {grid_mcl: {sessions_per_worker: auto}}}")
                .sessions_per_worker_of("grid_mcl"),
            locd::server::WorkerSettings::kAuto);
  EXPECT_EQ(parse("plugin_workers: {workers_per_plugin: 3}").auto_worker_cap(), 3u);
  EXPECT_DOUBLE_EQ(
      ServerConfig::parse("plugin_workers: {liveness_timeout_s: 2}", "t.yaml", kBase).plugin_workers.liveness_timeout_s,
      2.0);
}

TEST(ServerConfig, RequestLimitsPerKindWithTheirDefaults) {
  using locd::server::RequestKind;
  const auto c = ServerConfig::parse("request_limits: {initial_poses: {per_s: 0.5, burst: 2}}\n", "t.yaml", kBase);
  EXPECT_DOUBLE_EQ(c.request_limits.of(RequestKind::kInitialPose).per_s, 0.5);
  EXPECT_DOUBLE_EQ(c.request_limits.of(RequestKind::kInitialPose).burst, 2.0);
  const locd::server::RequestLimits defaults;
  EXPECT_DOUBLE_EQ(c.request_limits.of(RequestKind::kSessionRequest).per_s,
                   defaults.of(RequestKind::kSessionRequest).per_s);
  EXPECT_DOUBLE_EQ(c.request_limits.of(RequestKind::kMapSave).burst, defaults.of(RequestKind::kMapSave).burst);
  expect_error("request_limits: {session_requests: {per_s: 0}}",
               {"'request_limits.session_requests.per_s'", "allowed: [0.001, 1e+06]"});
  expect_error("request_limits: {map_saves: {burst: 0}}", {"'request_limits.map_saves.burst'", "allowed: [1, 1000000]"});
  expect_error("request_limits: {map_saves: {rate: 1}}", {"unknown parameter 'request_limits.map_saves.rate'", "per_s"});
  expect_error("request_limits: {poses: {}}", {"unknown parameter 'request_limits.poses'", "initial_poses"});
  const auto p = ServerConfig::parse("request_limits: {session_requests_per_participant: {per_s: 50, burst: 500}}\n",
                                     "t.yaml", kBase);
  EXPECT_DOUBLE_EQ(p.request_limits.session_requests_per_participant.per_s, 50.0);
  EXPECT_DOUBLE_EQ(p.request_limits.session_requests_per_participant.burst, 500.0);
  EXPECT_DOUBLE_EQ(ServerConfig::parse("", "t.yaml", kBase).request_limits.session_requests_per_participant.burst,
                   2000.0);
}

TEST(ServerConfig, UnknownKeysNameTheKeyWhereItStandsAndTheKnownOnes) {
  expect_error("domain_id: 1\nworker: 3\n", {"unknown parameter 'worker'", "line 2, column 1", "known:", "workers"});
  expect_error("limits:\n  max_beams: 3\n", {"unknown parameter 'limits.max_beams'", "line 2", "max_scan_beams"});
}

TEST(ServerConfig, MalformedYamlNamesLineAndColumn) {
  expect_error("domain_id: 1\nworkers: [2\n", {"test.yaml", "malformed YAML at line", "column"});
}

TEST(ServerConfig, BootSessionWithInlineConfig) {
  const auto c = ServerConfig::parse(R"(
sessions:
  - robot_id: robot1
    plugin: feature_ekf
    config: {plugin: feature_ekf, params: {map: corridor.yaml, gate_probability: 0.99}}
    initial_pose: [1.0, 2.0, 0.5]
)", "boot.yaml", kBase);
  ASSERT_EQ(c.sessions.size(), 1u);
  const auto& s = c.sessions[0];
  EXPECT_EQ(s.robot_id, "robot1");
  EXPECT_EQ(s.config.plugin, "feature_ekf");
  EXPECT_EQ(s.config.params.path(), "feature_ekf");
  EXPECT_DOUBLE_EQ(s.config.params.number("gate_probability", 0.0), 0.99);
  ASSERT_TRUE(s.initial_pose.has_value());
  EXPECT_DOUBLE_EQ((*s.initial_pose)[2], 0.5);
}

TEST(ServerConfig, BootSessionConfigFileResolvesAgainstTheConfigFolder) {
  const fs::path dir = fs::temp_directory_path() / ("locd_server_config_test_" + std::to_string(::getpid()));
  fs::create_directories(dir / "robots");
  std::ofstream(dir / "robots" / "r1.yaml") << "plugin: fixture_odometry\nparams:\n  position_stddev: 0.2\n";
  std::ofstream(dir / "locd.yaml") << "sessions:\n  - {robot_id: r1, config_file: robots/r1.yaml}\n";
  const auto c = ServerConfig::load_file(dir / "locd.yaml");
  ASSERT_EQ(c.sessions.size(), 1u);
  EXPECT_EQ(c.sessions[0].config.plugin, "fixture_odometry");
  EXPECT_EQ(c.sessions[0].source, (dir / "robots" / "r1.yaml").string());
  EXPECT_DOUBLE_EQ(c.sessions[0].config.params.number("position_stddev", 0.0), 0.2);
  fs::remove_all(dir);
}

TEST(ServerConfig, BadBootSessionsAreNamed) {
  expect_error("sessions:\n  - {robot_id: r1}\n", {"needs exactly one of 'config_file'", "'config'"});
  expect_error("sessions:\n  - {robot_id: r1, config_file: a.yaml, config: {plugin: x}}\n", {"exactly one of"});
  expect_error("sessions:\n  - {robot_id: r1, config_file: missing.yaml}\n",
               {"cannot read config file '/srv/locd/config/missing.yaml'"});
  expect_error("sessions:\n  - {robot_id: r1, plugin: other, config: {plugin: fixture_odometry}}\n",
               {"'sessions[0].plugin'", "differs from the config's plugin 'fixture_odometry'"});
  expect_error("sessions:\n  - {robot_id: r1, config: {plugin: ../x.so}}\n", {"plugin must be a name, not a path"});
  expect_error("sessions:\n  - {robot_id: r1, config: {plugin: a, param: {}}}\n", {"unknown parameter 'sessions[0].config.param'", "known: plugin, params"});
  expect_error("sessions:\n  - {robot_id: r1, config: {plugin: a}, initial_pose: [1, 2]}\n",
               {"'sessions[0].initial_pose'", "has 2 entries; expected a list of 3 numbers"});
  expect_error("sessions:\n  - {robot_id: r1, config: {plugin: a}}\n  - {robot_id: r1, config: {plugin: a}}\n",
               {"names robot 'r1' twice"});
  expect_error("sessions:\n  - {robot_id: r1, config: {plugin: a}, colour: red}\n",
               {"unknown parameter 'sessions[0].colour'"});
}

}  // namespace
