// Session ownership without DDS: which robots still have a live writer (RobotWriterPresence, the
// bridge's half), the server ending a remote session session_grace_s after its robot went (and
// not when it came back, nor a boot session), and Cyclone's log lines forwarded once per period.
#include <gtest/gtest.h>

#include <thread>

#include "test_plugin_index.hpp"
#include "locd/server/dds_log.hpp"
#include "locd/server/server.hpp"
#include "locd/server/writer_presence.hpp"
#include "recording_sink.hpp"

namespace {

using namespace locd;
using namespace locd::server;
using namespace std::chrono_literals;
using locd::server::test::RecordingSink;

TEST(RobotWriterPresence, ARobotIsPresentWhileAnyInputHasALiveWriter) {
  RobotWriterPresence presence(8);
  EXPECT_EQ(presence.update("r1", 0, true), std::optional<bool>(true));  // first writer: present
  EXPECT_EQ(presence.update("r1", 0, true), std::nullopt);               // no change
  EXPECT_EQ(presence.update("r1", 6, true), std::nullopt);
  EXPECT_EQ(presence.update("r1", 0, false), std::nullopt);  // input 6 still has one
  EXPECT_TRUE(presence.present("r1"));
  EXPECT_EQ(presence.update("r1", 6, false), std::optional<bool>(false));  // the last one went
  EXPECT_FALSE(presence.present("r1"));
  EXPECT_EQ(presence.update("r1", 6, false), std::nullopt);  // gone twice: no second report
  EXPECT_EQ(presence.update("never_seen", 3, false), std::nullopt);
}

TEST(RobotWriterPresence, BeyondItsBoundANewRobotIsNotTracked) {
  RobotWriterPresence presence(2);
  EXPECT_TRUE(presence.update("a", 0, true).has_value());
  EXPECT_TRUE(presence.update("b", 0, true).has_value());
  EXPECT_FALSE(presence.update("c", 0, true).has_value());
  EXPECT_FALSE(presence.present("c"));
  EXPECT_EQ(presence.update("a", 0, false), std::optional<bool>(false));  // room again
  EXPECT_EQ(presence.update("c", 0, true), std::optional<bool>(true));
}

class SessionOwnershipTest : public ::testing::Test {
 protected:
  SessionOwnershipTest() : catalog_(locd::server::test::plugin_index(LOCD_BROKEN_PLUGIN_DIR)) {
    config_.server_id = "ownership-test";
    config_.session_grace_s = 0.2;
    config_.plugin_workers.executable = LOCD_WORKER_EXECUTABLE;
    BootSession boot;
    boot.robot_id = "booted";
    boot.config.plugin = "fixture_odometry";
    boot.text = {"plugin: fixture_odometry\n", "test", {}};
    boot.source = "test";
    config_.sessions.push_back(boot);
    logger_.set_level(LogLevel::kError);
    server_ = std::make_unique<Server>(config_, catalog_, sink_, logger_);
  }
  ~SessionOwnershipTest() override { server_->shutdown(); }

  void start(const std::string& robot) {
    server_->on_robot_writers(robot, true);
    server_->on_session_request({robot, 1, false, "", "plugin: fixture_odometry\n"});
    ASSERT_TRUE(sink_.wait_status(robot, [](const SessionStatusReport& s) { return s.state == SessionState::kRunning; }));
  }

  ServerConfig config_;
  PluginIndex catalog_;
  RecordingSink sink_;
  Logger logger_;
  std::unique_ptr<Server> server_;
};

TEST_F(SessionOwnershipTest, ASessionEndsAfterTheGracePeriodOnceItsRobotHasNoLiveWriter) {
  start("r1");
  server_->on_robot_writers("r1", false);
  server_->end_ownerless_sessions();
  EXPECT_NE(server_->find("r1"), nullptr) << "ended before the grace period";
  std::this_thread::sleep_for(300ms);
  server_->end_ownerless_sessions();
  EXPECT_EQ(server_->find("r1"), nullptr);
  const auto stopped = sink_.wait_status("r1", [](const SessionStatusReport& s) { return s.state == SessionState::kStopped; });
  ASSERT_TRUE(stopped.has_value());
  EXPECT_NE(stopped->message.find("session ended: no live writer of robot 'r1'"), std::string::npos) << stopped->message;
  EXPECT_NE(stopped->message.find("for 0.2 s (session_grace_s)"), std::string::npos) << stopped->message;
}

TEST_F(SessionOwnershipTest, ARobotBackWithinTheGracePeriodKeepsItsSession) {
  start("r1");
  server_->on_robot_writers("r1", false);
  std::this_thread::sleep_for(100ms);
  server_->on_robot_writers("r1", true);
  std::this_thread::sleep_for(200ms);
  server_->end_ownerless_sessions();
  EXPECT_NE(server_->find("r1"), nullptr);
}

TEST_F(SessionOwnershipTest, BootSessionsAndRobotsWithoutASessionAreLeftAlone) {
  server_->boot();
  ASSERT_TRUE(sink_.wait_status("booted", [](const SessionStatusReport& s) { return s.state == SessionState::kRunning; }));
  server_->on_robot_writers("booted", false);
  server_->on_robot_writers("nobody", false);
  std::this_thread::sleep_for(300ms);
  server_->end_ownerless_sessions();
  EXPECT_NE(server_->find("booted"), nullptr);
  EXPECT_EQ(server_->find("nobody"), nullptr);
}

TEST(DdsLogForwarder, TheSameLineIsLoggedOncePerPeriodThenSaysHowManyWereLeftOut) {
  Logger logger;
  DdsLogForwarder forwarder(logger, std::chrono::seconds(1));
  testing::internal::CaptureStderr();
  forwarder.forward(dds::LogLevel::kWarning, "handshake failed; subject: /CN=x\n(code: 200)");
  for (int i = 0; i < 3; ++i) forwarder.forward(dds::LogLevel::kWarning, "handshake failed; subject: /CN=x\n(code: 200)");
  forwarder.forward(dds::LogLevel::kError, "other");
  std::this_thread::sleep_for(1100ms);
  forwarder.forward(dds::LogLevel::kWarning, "handshake failed; subject: /CN=x\n(code: 200)");
  const std::string out = testing::internal::GetCapturedStderr();
  // One line each, escaped by the Logger; the repeat after the period counts the three left out.
  EXPECT_NE(out.find("warning [dds] handshake failed; subject: /CN=x\\n(code: 200)\n"), std::string::npos) << out;
  EXPECT_NE(out.find("error [dds] other\n"), std::string::npos) << out;
  EXPECT_NE(out.find("(code: 200) (and 3 times more since the last line)"), std::string::npos) << out;
  size_t lines = 0;
  for (char c : out) lines += c == '\n';
  EXPECT_EQ(lines, 3u) << out;
}

TEST(DdsLogForwarder, AFloodOfDifferentLinesIsCutToTheRateAndCounted) {
  Logger logger;
  DdsLogForwarder forwarder(logger);
  testing::internal::CaptureStderr();
  for (int i = 0; i < 100; ++i) forwarder.forward(dds::LogLevel::kWarning, "peer " + std::to_string(i) + " refused");
  std::this_thread::sleep_for(1100ms);
  forwarder.forward(dds::LogLevel::kWarning, "after the flood");
  const std::string out = testing::internal::GetCapturedStderr();
  size_t lines = 0;
  for (char c : out) lines += c == '\n';
  EXPECT_EQ(lines, static_cast<size_t>(DdsLogForwarder::kMaxLinesPerSecond) + 1) << out;
  EXPECT_NE(out.find("after the flood (80 other DDS lines left out: more than 20 a second)"), std::string::npos) << out;
}

}  // namespace
