// The worker sandbox against a real locd over real DDS (loopback, domain 231): robot B's plugin is
// malicious (tests/broken_plugins/malicious.cpp). At load (in the inspector and in its worker) and
// in its first update it tries to read the server's key file, to open sockets, to read the
// server's DDS identity and a secret from its environment, and to forge locd log lines. None
// succeeds, each refusal reaches locd's log quoted and escaped, and robot A, served by another
// plugin beside it, gets every pose.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "eventually.hpp"
#include "robot_side.hpp"
#include "test_server.hpp"

namespace {

using locd::test::RobotSide;
using locd::test::TestServer;
using locd::test::TestServerOptions;

constexpr int kDomain = 231;
constexpr int64_t kPeriodNs = 50'000'000;

class Driver {
 public:
  explicit Driver(RobotSide& robot)
      : robot_(robot),
        odometry_(robot.participant(), locd::topics::kOdometry, locd::dds::QosProfile::kSensor, 64, robot.partition()) {}
  ::testing::AssertionResult matched() { return robot_.wait_matched(odometry_); }
  void send(int k) {
    locd::Odometry o;
    o.header = {k * kPeriodNs, "odom"};
    o.pose.translation() = Eigen::Vector3d(0.1 * k, 0.0, 0.0);
    locd::dds::write(odometry_, robot_.robot_id(), o);
  }

 private:
  RobotSide& robot_;
  locd::dds::Writer<locd_msg_Odometry> odometry_;
};

TEST(ServerSandbox, AMaliciousPluginReadsNoKeyOpensNoSocketSeesNoSecretAndForgesNoLogLine) {
  const std::filesystem::path key = LOCD_MALICIOUS_SECRET_FILE;
  std::filesystem::create_directories(key.parent_path());
  std::ofstream(key) << "KEY-MARKER-7f3a\n";
  std::filesystem::permissions(key, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  ASSERT_NE(locd::test::read_text(key).find("KEY-MARKER"), std::string::npos);  // readable to locd's user

  TestServerOptions options;
  options.extra_plugin_directory = std::string(LOCD_BROKEN_PLUGIN_DIR) + ", " + LOCD_MALICIOUS_PLUGIN_DIR;
  options.environment = {"LOCD_IDENTITY=" + key.parent_path().string(), "LOCD_TEST_SECRET=ENV-MARKER-91c2"};
  TestServer server("locd_sandbox", kDomain, options);
  RobotSide a(kDomain, "robot_a", server.process());
  RobotSide b(kDomain, "robot_b", server.process());
  Driver drive_a(a), drive_b(b);
  ASSERT_TRUE(drive_a.matched());
  ASSERT_TRUE(drive_b.matched());
  ASSERT_TRUE(a.start("", "plugin: fixture_odometry\n"));
  ASSERT_TRUE(b.start("", "plugin: malicious\n"));
  constexpr int kSteps = 20;
  for (int k = 1; k <= kSteps; ++k) {
    drive_a.send(k);
    drive_b.send(k);
    std::this_thread::sleep_for(std::chrono::nanoseconds(kPeriodNs));
  }
  for (int k = 1; k <= kSteps; ++k) ASSERT_TRUE(a.wait_pose(k * kPeriodNs)) << "robot a lost the pose of step " << k;
  ASSERT_TRUE(b.wait_pose(kSteps * kPeriodNs));  // the malicious plugin still serves its robot
  EXPECT_EQ(a.status_now().failures, 0u);

  std::string log;
  ASSERT_TRUE(locd::test::eventually([&] {
    log = server.process().output();
    return log.find("malicious: update: env LOCD_TEST_SECRET") != std::string::npos;
  })) << log;
  // In the inspector, in the worker at load, and in update: never in locd itself.
  EXPECT_EQ(log.find("malicious: constructor in pid " + std::to_string(server.process().pid()) + "\""),
            std::string::npos) << log;
  EXPECT_NE(log.find("malicious: update in pid "), std::string::npos) << log;
  EXPECT_NE(log.find("malicious: update: open " + key.string() + ": Permission denied"), std::string::npos) << log;
  EXPECT_NE(log.find("malicious: update: socket(AF_INET): Operation not permitted"), std::string::npos) << log;
  EXPECT_NE(log.find("malicious: update: env CYCLONEDDS_URI unset"), std::string::npos) << log;
  EXPECT_NE(log.find("malicious: update: env LOCD_IDENTITY unset"), std::string::npos) << log;
  for (const char* leak : {"KEY-MARKER", "ENV-MARKER", "LEAKED", "READ ", "CONNECTED", "MADE a Unix socket"}) {
    EXPECT_EQ(log.find(leak), std::string::npos) << leak << " in\n" << log;
  }
  std::istringstream lines(log);
  int forged = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.find("FORGED-LOG-LINE") == std::string::npos) continue;
    ++forged;
    EXPECT_EQ(line.rfind("2026-01-01T00:00:00.000Z", 0), std::string::npos) << line;
    EXPECT_NE(line.find("wrote to stderr: \"2026-01-01T00:00:00.000Z error [robot_a] FORGED-LOG-LINE"), std::string::npos)
        << line;
  }
  EXPECT_GE(forged, 2) << log;
}

}  // namespace
