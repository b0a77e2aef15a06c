// locsim live as people run it: the real locsim binary against the real locd over loopback DDS,
// both as child processes (feature_ekf on the corridor; icp_explorer's exploration mission, which
// drives the robot to the goals the server publishes); the localization state read from the
// server's status around a kidnap; and locsim live with no server.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>

#include "child_process.hpp"
#include "locsim_paths.hpp"

namespace fs = std::filesystem;
using namespace std::chrono_literals;

namespace {

constexpr uint32_t kDomainLive = 30;
constexpr uint32_t kDomainNoServer = 31;
constexpr uint32_t kDomainExploration = 32;
constexpr uint32_t kDomainKidnap = 180;

std::string binary(const std::string& name) { return locd::sim::test::binary_dir() + "/bin/" + name; }

double json_number(const std::string& json, const std::string& key) {
  std::smatch m;
  if (!std::regex_search(json, m, std::regex("\"" + key + "\": ?([-0-9.e+]+)"))) return NAN;
  return std::stod(m[1]);
}

fs::path scratch(const std::string& name) {
  std::random_device random;
  const fs::path dir = fs::temp_directory_path() / (name + std::to_string(random()));
  fs::create_directories(dir);
  return dir;
}

}  // namespace

TEST(LocsimLive, CorridorAgainstLocdIsScoredWithLatencies) {
  const fs::path dir = scratch("locsim_live_");
  const std::string source = locd::sim::test::source_dir();
  const fs::path server_config = dir / "locd.yaml";
  std::ofstream(server_config) << "domain_id: " << kDomainLive << "\nplugin_directories: [" << locd::sim::test::plugin_dir()
                               << "]\nmap_directories: [" << source << "/config/maps]\n";
  locd::test::ChildProcess server(binary("locd"), {"--config", server_config.string()}, (dir / "locd.log").string());
  const fs::path plot = dir / "live.png";
  locd::test::ChildProcess sim(binary("locsim"),
                               {"live", source + "/config/scenarios/corridor.yaml", "--domain", std::to_string(kDomainLive),
                                "--duration", "8", "--json", "--plot", plot.string(), "--server-timeout", "20"},
                               (dir / "locsim.log").string());
  const int code = sim.wait(90s);
  const std::string output = sim.output();
  ASSERT_EQ(code, 0) << output << "\nserver log:\n" << server.output();
  // One progress line a second, then the JSON summary.
  EXPECT_TRUE(std::regex_search(output, std::regex("t=5\\.0s robot=corridor_bot plugin=feature_ekf error=[0-9.]+m "
                                                   "update=[0-9.]+ms latency=[0-9.]+ms poses=[0-9]+")))
      << output;
  EXPECT_GT(json_number(output, "updates"), 100);  // 8 s of 25 Hz scans, some may be dropped
  EXPECT_LT(json_number(output, "rmse_m"), 0.05) << output;
  EXPECT_GT(json_number(output, "latency_ms_p50"), 0.0) << output;
  EXPECT_GE(json_number(output, "latency_ms_p99"), json_number(output, "latency_ms_p50")) << output;
  EXPECT_NE(output.find("\"converged\":true"), std::string::npos) << output;
  EXPECT_TRUE(fs::exists(plot));
  server.signal(SIGINT);
  EXPECT_EQ(server.wait(20s), 0) << server.output();
  fs::remove_all(dir);
}

TEST(LocsimLive, ExplorationMissionDrivesToTheServersGoals) {
  const fs::path dir = scratch("locsim_live_explore_");
  const std::string source = locd::sim::test::source_dir();
  const fs::path server_config = dir / "locd.yaml";
  std::ofstream(server_config) << "domain_id: " << kDomainExploration << "\nplugin_directories: ["
                               << locd::sim::test::plugin_dir() << "]\n";
  locd::test::ChildProcess server(binary("locd"), {"--config", server_config.string()}, (dir / "locd.log").string());
  // The shipped mission, three stops, a coarser scanner to keep the test short.
  const fs::path scenario = dir / "four_rooms_short.yaml";
  std::ofstream(scenario) << "kind: icp_explorer_exploration\nname: four_rooms_short\nseed: 1\n"
                          << "world: " << source << "/config/maps/four_rooms_3d.yaml\n"
                          << "robot: {id: live_explorer, start: [3.0, 3.0, 0.0], radius: 0.3}\n"
                          << "sensors:\n  scanner3d: {azimuth_steps: 360, elevation_steps: 70, sensor_height: 0.8}\n"
                          << "  odometry: {max_translation_error: 0.5, max_rotation_error_deg: 10}\n"
                          << "mission: {max_scans: 3, target_coverage: 0.95}\n"
                          << "localizer: {config_file: " << source << "/config/plugins/icp_explorer.yaml}\n";
  locd::test::ChildProcess sim(binary("locsim"),
                               {"live", scenario.string(), "--domain", std::to_string(kDomainExploration), "--json",
                                "--server-timeout", "60"},
                               (dir / "locsim.log").string());
  const int code = sim.wait(150s);
  const std::string output = sim.output();
  ASSERT_EQ(code, 0) << output << "\nserver log:\n" << server.output();
  EXPECT_EQ(json_number(output, "scans"), 3) << output;  // each stop after the first is a goal of the server
  EXPECT_GT(json_number(output, "path_length_m"), 1.0) << output;
  EXPECT_GT(json_number(output, "coverage"), 0.3) << output;
  EXPECT_LT(json_number(output, "max_error_m"), 0.05) << output;
  server.signal(SIGINT);
  EXPECT_EQ(server.wait(20s), 0) << server.output();
  fs::remove_all(dir);
}

TEST(LocsimLive, NoServerIsAClearErrorAndNonZeroExit) {
  const fs::path dir = scratch("locsim_noserver_");
  locd::test::ChildProcess sim(binary("locsim"),
                               {"live", locd::sim::test::source_dir() + "/config/scenarios/corridor.yaml", "--domain",
                                std::to_string(kDomainNoServer), "--server-timeout", "1.5"},
                               (dir / "locsim.log").string());
  const int code = sim.wait(30s);
  EXPECT_EQ(code, 2) << sim.output();
  EXPECT_NE(sim.output().find("no locd server answered on DDS domain 31"), std::string::npos) << sim.output();
  fs::remove_all(dir);
}

TEST(LocsimRun, BadArgumentsAndJsonOutput) {
  const fs::path dir = scratch("locsim_run_");
  {
    locd::test::ChildProcess sim(binary("locsim"), {"run", "--duration", "abc"}, (dir / "a.log").string());
    EXPECT_EQ(sim.wait(30s), 2);
    EXPECT_NE(sim.output().find("--duration abc: expected a number"), std::string::npos) << sim.output();
  }
  {
    locd::test::ChildProcess sim(binary("locsim"),
                                 {"run", locd::sim::test::source_dir() + "/config/scenarios/corridor.yaml", "--json",
                                  "--duration", "5", "--plugin-dir", locd::sim::test::plugin_dir()},
                                 (dir / "b.log").string());
    EXPECT_EQ(sim.wait(60s), 0) << sim.output();
    const std::string out = sim.output();
    for (const char* key : {"plugin", "scenario", "seed", "updates", "mean_error_m", "rmse_m", "p95_error_m", "max_error_m",
                            "final_error_m", "mean_heading_error_deg", "update_ms_p50", "update_ms_p99", "converged",
                            "convergence_time_s"}) {
      EXPECT_NE(out.find("\"" + std::string(key) + "\":"), std::string::npos) << key << " missing in " << out;
    }
    EXPECT_NEAR(json_number(out, "updates"), 126, 1);  // 25 Hz scans over 5 s, both ends
  }
  fs::remove_all(dir);
}

// The state comes from locd/session_status: feature_ekf says tracking, then lost within a second of
// the kidnap; locsim attributes each status to the poses it arrived with and scores it.
TEST(LocsimLive, KidnapIsReportedOnTheStatus) {
  const fs::path dir = scratch("locsim_live_kidnap_");
  const std::string source = locd::sim::test::source_dir();
  const fs::path server_config = dir / "locd.yaml";
  std::ofstream(server_config) << "domain_id: " << kDomainKidnap << "\nplugin_directories: ["
                               << locd::sim::test::plugin_dir() << "]\nmap_directories: [" << source << "/config/maps]\n";
  locd::test::ChildProcess server(binary("locd"), {"--config", server_config.string()}, (dir / "locd.log").string());
  locd::test::ChildProcess sim(binary("locsim"),
                               {"live", source + "/config/scenarios/corridor.yaml", "--domain", std::to_string(kDomainKidnap),
                                "--duration", "12", "--rate", "2", "--kidnap-at", "4", "--json", "--server-timeout", "20"},
                               (dir / "locsim.log").string());
  const int code = sim.wait(90s);
  const std::string output = sim.output();
  ASSERT_EQ(code, 0) << output << "\nserver log:\n" << server.output();
  EXPECT_NE(output.find("\"event\":\"kidnap\""), std::string::npos) << output;
  const double delay = json_number(output, "detection_delay_s");
  EXPECT_GE(delay, 0.0) << output;
  EXPECT_LT(delay, 5.0) << output;
  EXPECT_GT(json_number(output, "tracking_share"), 0.3) << output;
  EXPECT_GT(json_number(output, "lost_share"), 0.0) << output;
  // The server logged the change of state with its criterion.
  EXPECT_NE(server.output().find("localization lost"), std::string::npos) << server.output();
  server.signal(SIGINT);
  EXPECT_EQ(server.wait(20s), 0) << server.output();
  fs::remove_all(dir);
}
