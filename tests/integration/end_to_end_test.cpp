// End to end over real Cyclone DDS on loopback: the real locd, the real feature_ekf plugin and
// `locsim live` streaming the corridor robot; poses are scored against the simulator's truth.
// Domains 10-19.
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <regex>
#include <thread>

#include "locd/client/client.hpp"
#include "test_server.hpp"

namespace fs = std::filesystem;
using namespace std::chrono_literals;

namespace {

std::unique_ptr<locd::test::ChildProcess> start_locsim_live(const fs::path& dir, int domain, double duration_s) {
  return std::make_unique<locd::test::ChildProcess>(
      locd::test::binary_dir() + "/bin/locsim",
      std::vector<std::string>{"live", locd::test::source_dir() + "/config/scenarios/corridor.yaml", "--domain",
                               std::to_string(domain), "--duration", std::to_string(duration_s), "--json"},
      (dir / "locsim.log").string());
}

// A number field of locsim's one-line JSON summary; NaN when absent.
double json_field(const std::string& output, const std::string& key) {
  const std::regex pattern("\"" + key + "\": ?(-?[0-9.eE+-]+)");
  std::smatch m;
  return std::regex_search(output, m, pattern) ? std::stod(m[1]) : std::nan("");
}

}  // namespace

TEST(EndToEnd, CorridorRobotIsLocalizedOverDds) {
  constexpr int kDomain = 10;
  locd::test::TestServer locd("end_to_end", kDomain);
  auto locsim = start_locsim_live(locd.dir(), kDomain, 20.0);
  ASSERT_EQ(locsim->wait(120s), 0) << locsim->output() << "\nlocd log:\n" << locd.process().output();
  const std::string out = locsim->output();
  EXPECT_LT(json_field(out, "rmse_m"), 0.1) << out;
  EXPECT_LT(json_field(out, "max_error_m"), 0.3) << out;
  EXPECT_GT(json_field(out, "updates"), 250) << out;  // 20 s of 25 Hz scans, most of them answered
  EXPECT_NE(out.find("\"converged\":true"), std::string::npos) << out;
  EXPECT_TRUE(locd.process().running()) << locd.process().output();
}

TEST(EndToEnd, SwitchingPluginMidStreamHandsOverThePose) {
  constexpr int kDomain = 11;
  locd::test::TestServer locd("end_to_end", kDomain);
  auto locsim = start_locsim_live(locd.dir(), kDomain, 16.0);

  // A second program (an operator, another robot) watches the corridor robot and switches its
  // localizer while it drives: a new feature_ekf instance with another gate, handed the last pose.
  locd::Client operator_client({.domain_id = kDomain, .robot_id = "corridor_bot"});
  std::atomic<int> poses{0};
  operator_client.on_pose([&](const locd::PoseUpdate&) { ++poses; }, "corridor_bot");
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (poses < 100 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(20ms);
  ASSERT_GE(poses.load(), 100) << locsim->output() << "\nlocd log:\n" << locd.process().output();

  std::ifstream in(locd::test::source_dir() + "/config/plugins/feature_ekf.yaml");
  std::string yaml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  yaml = std::regex_replace(yaml, std::regex("gate_probability: 0\\.99\\b"), "gate_probability: 0.995");
  ASSERT_NE(yaml.find("gate_probability: 0.995"), std::string::npos);
  const auto status = operator_client.request_session("feature_ekf", yaml, 10s);
  ASSERT_TRUE(status.has_value()) << locd.process().output();
  EXPECT_TRUE(status->request_ok) << status->message;
  EXPECT_EQ(status->plugin, "feature_ekf");
  const int poses_at_switch = poses;

  ASSERT_EQ(locsim->wait(120s), 0) << locsim->output() << "\nlocd log:\n" << locd.process().output();
  const std::string out = locsim->output();
  EXPECT_GT(poses.load(), poses_at_switch + 50) << "poses stopped after the switch";
  // Without the handed-over pose the new instance would start from its config's initial pose
  // (0, 0) and the error would jump by metres.
  EXPECT_LT(json_field(out, "max_error_m"), 0.3) << out;
  EXPECT_LT(json_field(out, "rmse_m"), 0.1) << out;
  EXPECT_NE(locd.process().output().find("switched plugin feature_ekf -> feature_ekf"), std::string::npos)
      << locd.process().output();
}
