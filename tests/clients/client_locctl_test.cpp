// locctl as people run it: the real binary as a child process, against the real locd server
// (build/bin/locd with the feature_ekf plugin) over loopback DDS. Checks exit codes and output:
// argument errors, configs refused before sending, no server, use / status / plugins / stop /
// initial-pose, and watch printing the poses of a robot whose scans the test ray-casts in the
// corridor world.
#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <thread>

#include "child_process.hpp"
#include "locd/client/client.hpp"
#include "locd/sdk/feature_map.hpp"
#include "locd/sim/laser_scanner.hpp"
#include "locd/sim/world.hpp"
#include "test_env.hpp"

namespace locd {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

// True when process `pid` has a handler for `signal` (its SigCgt mask in /proc).
bool catches(pid_t pid, int signal) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("SigCgt:", 0) == 0) return (std::stoull(line.substr(7), nullptr, 16) >> (signal - 1)) & 1u;
  }
  return false;
}

constexpr uint32_t kDomainSessions = 44;
constexpr uint32_t kDomainWatch = 45;
constexpr uint32_t kDomainNoServer = 48;
constexpr uint32_t kDomainNeverContacted = 49;  // commands that must fail before any DDS traffic

class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "locctl_test_XXXXXX").string();
    if (!::mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  fs::path write(const std::string& name, const std::string& text) const {
    std::ofstream(path_ / name) << text;
    return path_ / name;
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string locctl_path() { return test::binary_dir() + "/bin/locctl"; }

struct LocctlRun {
  int exit_code;
  std::string output;  // stdout and stderr
};

LocctlRun locctl(const TempDir& dir, const std::vector<std::string>& args, std::chrono::milliseconds timeout = 60s) {
  static int counter = 0;
  test::ChildProcess child(locctl_path(), args, (dir.path() / ("locctl_" + std::to_string(++counter) + ".log")).string());
  const int code = child.wait(timeout);
  return {code, child.output()};
}

// The locd daemon on its own domain with the built plugins and the tree's maps.
class LocdServer {
 public:
  LocdServer(const TempDir& dir, uint32_t domain) : server_id_("client_test_" + std::to_string(domain)) {
    const fs::path config = dir.write("locd_" + std::to_string(domain) + ".yaml",
                                      "server_id: " + server_id_ + "\n" + "domain_id: " + std::to_string(domain) +
                                          "\n" + "plugin_directories: [" + test::plugin_dir() + "]\n" +
                                          "map_directories: [" + test::source_dir() + "/config/maps]\n" +
                                          "status_period_s: 0.2\n");
    process_ = std::make_unique<test::ChildProcess>(test::binary_dir() + "/bin/locd",
                                                    std::vector<std::string>{"--config", config.string()},
                                                    (dir.path() / ("locd_" + std::to_string(domain) + ".log")).string());
    Client probe({domain, "", 8});
    if (!probe.wait_for_server(30s)) {
      throw std::runtime_error("locd did not come up on domain " + std::to_string(domain) + ":\n" + process_->output());
    }
  }
  ~LocdServer() {
    process_->signal(SIGTERM);
    process_->wait(10s);
  }
  const std::string& server_id() const { return server_id_; }
  std::string log() const { return process_->output(); }

 private:
  std::string server_id_;
  std::unique_ptr<test::ChildProcess> process_;
};

const char* const kEkfConfig = "plugin: feature_ekf\nparams:\n  map: corridor.yaml\n  gate_probability: 0.99\n";

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// The number after "key": in one JSON line (locctl prints flat objects per pose).
double json_number(const std::string& line, const std::string& key) {
  const std::string tag = "\"" + key + "\":";
  const size_t at = line.find(tag);
  if (at == std::string::npos) throw std::runtime_error("no " + key + " in " + line);
  return std::strtod(line.c_str() + at + tag.size(), nullptr);
}

std::vector<std::string> lines_starting_with(const std::string& text, const std::string& prefix) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(prefix, 0) == 0) out.push_back(line);
  }
  return out;
}

TEST(Locctl, ArgumentErrorsExitWithStatusTwoAndSayWhatIsWrong) {
  TempDir dir;
  const std::string domain = std::to_string(kDomainNeverContacted);
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{}, "no command given"},
      {{"--domain", domain, "teleport"}, "unknown command 'teleport'"},
      {{"--domain", domain, "status", "--frobnicate"}, "unknown option '--frobnicate'"},
      {{"--domain", "233", "status"}, "--domain = '233' is not an integer in [0, 232]"},
      {{"--domain"}, "option --domain needs a value"},
      {{"--domain", domain, "--timeout", "-1", "status"}, "--timeout = -1 is out of range; allowed: (0, 86400]"},
      {{"--domain", domain, "--timeout", "soon", "status"}, "--timeout = 'soon' is not a finite number"},
      {{"--domain", domain, "use", "robot1"}, "'use' takes ROBOT CONFIG.yaml, got 1 argument(s)"},
      {{"--domain", domain, "watch"}, "'watch' takes ROBOT, got 0 argument(s)"},
      {{"--domain", domain, "status", "a", "b"}, "'status' takes [ROBOT], got 2 argument(s)"},
      {{"--domain", domain, "initial-pose", "robot1", "1", "north", "0"}, "Y = 'north' is not a finite number"},
      {{"--domain", domain, "status", "--count", "3"}, "--count applies to 'watch' only"},
      {{"--domain", domain, "watch", "robot1", "--count", "0"}, "--count = '0' is not an integer in [1, 1000000000]"},
      {{"--domain", domain, "stop", std::string(65, 'r')}, "is 65 characters; allowed: 1-64 characters of [A-Za-z0-9_.-]"},
      {{"--domain", domain, "stop", "robot\n1"}, "ROBOT: robot_id 'robot\\n1' contains '\\n'"},
      {{"--domain", domain, "watch", "robot.*"}, "contains '*'"},
  };
  for (const auto& c : cases) {
    const LocctlRun run = locctl(dir, c.args);
    EXPECT_EQ(run.exit_code, 2) << run.output;
    EXPECT_TRUE(contains(run.output, c.message)) << "expected '" << c.message << "' in: " << run.output;
  }
  const LocctlRun help = locctl(dir, {"--help"});
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_TRUE(contains(help.output, "usage: locctl"));
  EXPECT_TRUE(contains(help.output, "initial-pose ROBOT X Y YAW"));
  setenv("LOCD_DOMAIN", "999", 1);
  const LocctlRun bad_env = locctl(dir, {"status"});
  unsetenv("LOCD_DOMAIN");
  EXPECT_EQ(bad_env.exit_code, 2);
  EXPECT_TRUE(contains(bad_env.output, "LOCD_DOMAIN = '999'")) << bad_env.output;
}

TEST(Locctl, UseRefusesABadConfigFileBeforeSendingIt) {
  TempDir dir;
  const std::string domain = std::to_string(kDomainNeverContacted);
  const auto missing = locctl(dir, {"--domain", domain, "use", "robot1", (dir.path() / "absent.yaml").string()});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_TRUE(contains(missing.output, "cannot read config file")) << missing.output;
  EXPECT_TRUE(contains(missing.output, "absent.yaml")) << missing.output;

  const auto malformed = dir.write("malformed.yaml", "plugin: feature_ekf\nparams: [1, 2\n");
  const auto bad_yaml = locctl(dir, {"--domain", domain, "use", "robot1", malformed.string()});
  EXPECT_EQ(bad_yaml.exit_code, 1);
  EXPECT_TRUE(contains(bad_yaml.output, "malformed YAML at line 3, column 1")) << bad_yaml.output;

  const auto typo = dir.write("typo.yaml", "plugin: feature_ekf\nparms:\n  map: corridor.yaml\n");
  const auto unknown_key = locctl(dir, {"--domain", domain, "use", "robot1", typo.string()});
  EXPECT_EQ(unknown_key.exit_code, 1);
  EXPECT_TRUE(contains(unknown_key.output, "'parms' (line 2, column 1)")) << unknown_key.output;

  const auto path = dir.write("path.yaml", "plugin: ../lib/evil\nparams: {}\n");
  const auto path_plugin = locctl(dir, {"--domain", domain, "--json", "use", "robot1", path.string()});
  EXPECT_EQ(path_plugin.exit_code, 1);
  EXPECT_TRUE(contains(path_plugin.output, "{\"command\":\"use\",\"ok\":false,\"error\":")) << path_plugin.output;
  EXPECT_TRUE(contains(path_plugin.output, "plugin must be a name, not a path")) << path_plugin.output;
}

TEST(Locctl, NoServerFailsNamingTheDomainAndCycloneddsUri) {
  TempDir dir;
  const std::string domain = std::to_string(kDomainNoServer);
  const auto config = dir.write("ekf.yaml", kEkfConfig);
  const std::vector<std::vector<std::string>> commands = {
      {"status"}, {"plugins"}, {"use", "robot1", config.string()}, {"stop", "robot1"},
      {"initial-pose", "robot1", "1", "2", "0"}};
  for (const auto& command : commands) {
    std::vector<std::string> args = {"--domain", domain, "--timeout", "0.5"};
    args.insert(args.end(), command.begin(), command.end());
    const LocctlRun run = locctl(dir, args);
    EXPECT_EQ(run.exit_code, 1) << command[0] << ": " << run.output;
    EXPECT_TRUE(contains(run.output, "no locd server found on DDS domain " + domain)) << run.output;
    EXPECT_TRUE(contains(run.output, "CYCLONEDDS_URI=")) << run.output;
  }
  const LocctlRun json = locctl(dir, {"--domain", domain, "--timeout", "0.5", "--json", "status"});
  EXPECT_EQ(json.exit_code, 1);
  EXPECT_EQ(json.output.rfind("{\"command\":\"status\",\"ok\":false,\"error\":\"no locd server found", 0), 0u)
      << json.output;
  const LocctlRun watch = locctl(dir, {"--domain", domain, "--timeout", "0.5", "watch", "robot1"});
  EXPECT_EQ(watch.exit_code, 1);
  EXPECT_TRUE(contains(watch.output, "no pose for robot 'robot1' within 0.5 s")) << watch.output;

  // Without --count or --timeout, watch runs until Ctrl-C and then ends normally. Ctrl-C once its
  // handler is in place (a slow start must not meet the default action instead).
  test::ChildProcess endless(locctl_path(), {"--domain", domain, "watch", "robot1"}, (dir.path() / "endless.log").string());
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (!catches(endless.pid(), SIGINT) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(10ms);
  }
  endless.signal(SIGINT);
  EXPECT_EQ(endless.wait(10s), 0) << endless.output();
}

TEST(Locctl, UseStatusPluginsAndStopAgainstTheServer) {
  TempDir dir;
  LocdServer server(dir, kDomainSessions);
  const std::string domain = std::to_string(kDomainSessions);
  const auto config = dir.write("ekf.yaml", kEkfConfig);

  const LocctlRun plugins = locctl(dir, {"--domain", domain, "plugins"});
  EXPECT_EQ(plugins.exit_code, 0) << plugins.output;
  EXPECT_TRUE(contains(plugins.output, "server " + server.server_id() + ": ")) << plugins.output;
  EXPECT_TRUE(std::regex_search(plugins.output, std::regex("\n  feature_ekf \\S+  consumes odometry,imu,scan,detections  ")))
      << plugins.output;
  const LocctlRun plugins_json = locctl(dir, {"--domain", domain, "--json", "plugins"});
  EXPECT_EQ(plugins_json.exit_code, 0) << plugins_json.output;
  EXPECT_TRUE(contains(plugins_json.output, "{\"command\":\"plugins\",\"ok\":true,\"servers\":[{\"server\":\"" +
                                                server.server_id() + "\",\"plugins\":[")) << plugins_json.output;
  EXPECT_TRUE(contains(plugins_json.output, "{\"name\":\"feature_ekf\""))
      << plugins_json.output;
  EXPECT_TRUE(contains(plugins_json.output, "\"consumes\":[\"odometry\",\"imu\",\"scan\",\"detections\"]")) << plugins_json.output;

  const LocctlRun use = locctl(dir, {"--domain", domain, "use", "robot44", config.string()});
  EXPECT_EQ(use.exit_code, 0) << use.output << server.log();
  EXPECT_TRUE(contains(use.output, "robot44: ok by server " + server.server_id() + " (state running, plugin feature_ekf)"))
      << use.output;

  const LocctlRun status = locctl(dir, {"--domain", domain, "status", "robot44"});
  EXPECT_EQ(status.exit_code, 0) << status.output;
  EXPECT_TRUE(std::regex_search(status.output, std::regex("^ROBOT +STATE +PLUGIN +SERVER +RECEIVED")));
  EXPECT_TRUE(std::regex_search(status.output, std::regex("\nrobot44 +running +feature_ekf +" + server.server_id())))
      << status.output;

  // A parameter out of range: refused with the plugin's message; the running plugin carries on.
  const auto out_of_range = dir.write("bad.yaml",
                                      "plugin: feature_ekf\nparams:\n  map: corridor.yaml\n  gate_probability: 1.5\n");
  const LocctlRun refused = locctl(dir, {"--domain", domain, "--json", "use", "robot44", out_of_range.string()});
  EXPECT_EQ(refused.exit_code, 1) << refused.output;
  EXPECT_TRUE(contains(refused.output, "{\"command\":\"use\",\"ok\":false,\"status\":{\"robot\":\"robot44\""))
      << refused.output;
  EXPECT_TRUE(contains(refused.output, "\"state\":\"running\"")) << refused.output;
  EXPECT_TRUE(contains(refused.output, "parameter 'feature_ekf.gate_probability' (line 4, column 21) = 1.5")) << refused.output;

  // An unknown plugin: the server lists the ones it knows.
  const auto unknown = dir.write("unknown.yaml", "plugin: warp_drive\nparams: {}\n");
  const LocctlRun no_such = locctl(dir, {"--domain", domain, "use", "robot44b", unknown.string()});
  EXPECT_EQ(no_such.exit_code, 1) << no_such.output;
  EXPECT_TRUE(contains(no_such.output, "robot44b: refused by server " + server.server_id())) << no_such.output;
  EXPECT_TRUE(contains(no_such.output, "warp_drive")) << no_such.output;
  EXPECT_TRUE(contains(no_such.output, "feature_ekf")) << no_such.output;

  const LocctlRun all_json = locctl(dir, {"--domain", domain, "--json", "status"});
  EXPECT_EQ(all_json.exit_code, 0) << all_json.output;
  EXPECT_TRUE(contains(all_json.output, "\"servers\":[\"" + server.server_id() + "\"]")) << all_json.output;
  EXPECT_TRUE(contains(all_json.output, "{\"robot\":\"robot44\",\"server\":\"" + server.server_id() +
                                            "\",\"state\":\"running\",\"plugin\":\"feature_ekf\""))
      << all_json.output;

  const LocctlRun stop = locctl(dir, {"--domain", domain, "stop", "robot44"});
  EXPECT_EQ(stop.exit_code, 0) << stop.output;
  EXPECT_TRUE(contains(stop.output, "(state stopped")) << stop.output;
  const LocctlRun stop_again = locctl(dir, {"--domain", domain, "stop", "robot44"});
  EXPECT_EQ(stop_again.exit_code, 1) << stop_again.output;
  EXPECT_TRUE(contains(stop_again.output, "robot44: refused by server")) << stop_again.output;

  const LocctlRun unknown_robot = locctl(dir, {"--domain", domain, "status", "robot_nobody"});
  EXPECT_EQ(unknown_robot.exit_code, 1) << unknown_robot.output;
  EXPECT_TRUE(contains(unknown_robot.output, "robot 'robot_nobody' has no session")) << unknown_robot.output;
}

TEST(Locctl, WatchPrintsThePosesOfARobotStreamingScans) {
  TempDir dir;
  LocdServer server(dir, kDomainWatch);
  const std::string domain = std::to_string(kDomainWatch);
  const auto config = dir.write("ekf.yaml", kEkfConfig);

  // The robot stands still at the corridor scenario's start; its scans are ray-cast exactly
  // (1 cm noise) against the corridor walls.
  const Pose2 truth(3.0, 1.0, 0.0);
  const FeatureMap2D map = load_feature_map(test::source_dir() + "/config/maps/corridor.yaml", 100000);
  auto world = std::make_shared<const sim::SegmentWorld>(sim::SegmentWorld::from_feature_map(map));
  const sim::LaserScannerModel laser(sim::LaserScannerConfig{}, world);
  std::mt19937_64 rng(7);

  ASSERT_EQ(locctl(dir, {"--domain", domain, "use", "robot45", config.string()}).exit_code, 0) << server.log();
  const LocctlRun initial = locctl(dir, {"--domain", domain, "initial-pose", "robot45", "3.1", "0.95", "0.02", "--std-xy",
                                   "0.2", "--std-yaw", "0.05"});
  EXPECT_EQ(initial.exit_code, 0) << initial.output;
  EXPECT_TRUE(contains(initial.output, "robot45: initial pose x=3.1 y=0.95 yaw=0.02 rad held by plugin feature_ekf"))
      << initial.output;
  // Nobody runs robot46: the pose is never taken, and locctl says so.
  const LocctlRun orphan = locctl(dir, {"--domain", domain, "--timeout", "1", "initial-pose", "robot46", "1", "2", "0"});
  EXPECT_EQ(orphan.exit_code, 1) << orphan.output;
  EXPECT_TRUE(contains(orphan.output, "the initial pose for robot 'robot46' was not taken within 1")) << orphan.output;

  test::ChildProcess watch_json(locctl_path(),
                                {"--domain", domain, "--timeout", "30", "--json", "watch", "robot45", "--count", "5"},
                                (dir.path() / "watch_json.log").string());
  test::ChildProcess watch_text(locctl_path(), {"--domain", domain, "--timeout", "30", "watch", "robot45", "--count", "2"},
                                (dir.path() / "watch_text.log").string());
  Client robot({kDomainWatch, "robot45", 8});
  Odometry odometry;
  odometry.header.frame_id = "odom";
  const auto give_up = std::chrono::steady_clock::now() + 60s;
  // ChildProcess::running() reaps a child without keeping its status: watch the output instead.
  auto done = [&] {
    return lines_starting_with(watch_json.output(), "{").size() >= 5 &&
           lines_starting_with(watch_text.output(), "1").size() >= 2;
  };
  while (!done() && std::chrono::steady_clock::now() < give_up) {
    const int64_t stamp =
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
            .count();
    odometry.header.stamp_ns = stamp;
    robot.publish(odometry);
    robot.publish(laser.scan(truth, stamp, rng));
    std::this_thread::sleep_for(40ms);
  }
  ASSERT_EQ(watch_json.wait(10s), 0) << watch_json.output() << server.log();
  ASSERT_EQ(watch_text.wait(10s), 0) << watch_text.output();

  const auto poses = lines_starting_with(watch_json.output(), "{");
  ASSERT_EQ(poses.size(), 5u) << watch_json.output();
  for (const auto& line : poses) {
    EXPECT_TRUE(contains(line, "\"robot\":\"robot45\"")) << line;
    EXPECT_TRUE(contains(line, "\"plugin\":\"feature_ekf\"")) << line;
    EXPECT_GT(json_number(line, "stamp_ns"), 0.0) << line;
    EXPECT_NEAR(json_number(line, "x"), truth.x, 0.2) << line;
    EXPECT_NEAR(json_number(line, "y"), truth.y, 0.2) << line;
    EXPECT_NEAR(json_number(line, "yaw_deg"), 0.0, 5.0) << line;
    EXPECT_GT(json_number(line, "std_x"), 0.0) << line;
    EXPECT_GE(json_number(line, "update_ms"), 0.0) << line;
  }
  const std::regex text_line(R"(^\d+\.\d{6} x=-?\d+\.\d{3} y=-?\d+\.\d{3} yaw=-?\d+\.\d{2}deg std_x=\d+\.\d{3} std_y=\d+\.\d{3} plugin=feature_ekf update=\d+\.\d{3}ms$)");
  std::istringstream text(watch_text.output());
  int matching = 0;
  for (std::string line; std::getline(text, line);) matching += std::regex_match(line, text_line);
  EXPECT_EQ(matching, 2) << watch_text.output();

  // Statuses are periodic (0.2 s here): poll until the counters caught up with the poses seen.
  LocctlRun status{};
  for (int attempt = 0; attempt < 20; ++attempt) {
    status = locctl(dir, {"--domain", domain, "--json", "status", "robot45"});
    if (status.exit_code != 0 || json_number(status.output, "updates") >= 5.0) break;
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(status.exit_code, 0) << status.output;
  EXPECT_TRUE(contains(status.output, "\"servers\":[\"" + server.server_id() + "\"]")) << status.output;
  EXPECT_GE(json_number(status.output, "updates"), 5.0) << status.output;
  EXPECT_GE(json_number(status.output, "received"), json_number(status.output, "updates")) << status.output;
}

}  // namespace
}  // namespace locd
