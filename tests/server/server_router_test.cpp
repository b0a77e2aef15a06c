// The session router without DDS: requests through the real loader and the fixture plugins,
// bad requests answered on the status, messages for robots without a session, a plugin
// switch at run time and a failed switch that keeps the running plugin, and a stalled server's
// outputs withheld until it has heard the fleet again.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "test_plugin_index.hpp"
#include "locd/server/server.hpp"
#include "recording_sink.hpp"

namespace {

using namespace locd;
using namespace locd::server;
using locd::server::test::RecordingSink;

class ServerRouterTest : public ::testing::Test {
 protected:
  ServerRouterTest() : catalog_(locd::server::test::plugin_index(LOCD_BROKEN_PLUGIN_DIR)) {
    config_.server_id = "router-test";
    config_.queue_depth = 32;
    config_.plugin_workers.executable = LOCD_WORKER_EXECUTABLE;
    logger_.set_level(LogLevel::kError);
    server_ = std::make_unique<Server>(config_, catalog_, sink_, logger_);
  }
  ~ServerRouterTest() override { server_->shutdown(); }

  SessionStatusReport request(const std::string& robot, uint64_t id, const std::string& plugin, const std::string& yaml,
                              const std::string& source = "") {
    server_->on_session_request({robot, id, false, plugin, yaml, source});
    auto status = sink_.wait_status(robot, [&](const SessionStatusReport& s) { return s.request_id == id; });
    EXPECT_TRUE(status.has_value()) << "no status for request " << id;
    return status.value_or(SessionStatusReport{});
  }
  static Odometry odometry(int64_t stamp, double x) {
    Odometry o;
    o.header.stamp_ns = stamp;
    o.pose.translation() = Eigen::Vector3d(x, 0.0, 0.0);
    return o;
  }

  ServerConfig config_;
  PluginIndex catalog_;
  RecordingSink sink_;
  Logger logger_;
  std::unique_ptr<Server> server_;
};

TEST_F(ServerRouterTest, ServerInfoListsPluginsAndRefusedFiles) {
  server_->boot();
  const auto infos = sink_.infos();
  ASSERT_EQ(infos.size(), 1u);
  EXPECT_EQ(infos[0].server_id, "router-test");
  ASSERT_EQ(infos[0].plugins.size(), 4u);
  EXPECT_EQ(infos[0].plugins[3].name, "fixture_odometry");
  EXPECT_EQ(infos[0].plugins[3].consumes, (std::vector<std::string>{"odometry", "scan"}));
  EXPECT_EQ(infos[0].rejected_plugins.size(), 4u);
}

TEST_F(ServerRouterTest, GoodRequestRunsAndPublishesPosesStampedWithTheMeasurement) {
  const auto status = request("r1", 1, "", "plugin: fixture_odometry\nparams: {position_stddev: 0.2}\n");
  EXPECT_TRUE(status.request_ok) << status.message;
  EXPECT_EQ(status.state, SessionState::kRunning);
  EXPECT_EQ(status.plugin, "fixture_odometry");
  server_->on_measurement("r1", odometry(1000, 0.5));
  ASSERT_TRUE(sink_.wait_for([](const auto&, const auto& outputs) {
    return !outputs.empty() && outputs.back().result.estimate.has_value();
  }));
  const auto out = sink_.outputs().back();
  EXPECT_EQ(out.robot_id, "r1");
  EXPECT_EQ(out.plugin, "fixture_odometry");
  EXPECT_EQ(out.result.estimate->header.stamp_ns, 1000);
}

TEST_F(ServerRouterTest, BadRequestsAreAnsweredWithClearErrors) {
  auto s = request("r2", 1, "", "plugin: fixture_odometry\nparams: {position_stddev: [1\n");
  EXPECT_FALSE(s.request_ok);
  EXPECT_EQ(s.state, SessionState::kError);
  EXPECT_NE(s.message.find("malformed YAML at line 3, column 1"), std::string::npos) << s.message;

  s = request("r2", 2, "", "plugin: no_such_plugin\n");
  EXPECT_NE(s.message.find("unknown plugin 'no_such_plugin'; known plugins: broken_configure_throws, "
                           "broken_factory_throws, faulty, fixture_odometry"),
            std::string::npos)
      << s.message;

  s = request("r2", 3, "/tmp/evil.so", "plugin: fixture_odometry\n");
  EXPECT_NE(s.message.find("plugin must be a name, not a path"), std::string::npos) << s.message;

  s = request("r2", 4, "", "plugin: ../plugins/liblocd_fixture_odometry.so\n");
  EXPECT_NE(s.message.find("plugin must be a name, not a path"), std::string::npos) << s.message;

  s = request("r2", 5, "", "plugin: fixture_odometry\nparams: {position_stddev: -1}\n");
  EXPECT_NE(s.message.find("parameter 'fixture_odometry.position_stddev' (line 2, column 27) = -1 is out of range; "
                           "allowed: (0, inf]"),
            std::string::npos)
      << s.message;

  s = request("r2", 6, "broken_factory_throws", "plugin: fixture_odometry\n");
  EXPECT_NE(s.message.find("differs from the config's plugin 'fixture_odometry'"), std::string::npos) << s.message;

  s = request("r2", 7, "", "plugin: fixture_odometry\nextra: 1\n");
  EXPECT_NE(s.message.find("unknown parameter 'extra'"), std::string::npos) << s.message;

  // None of these left a session behind: a message for r2 is answered as "no session".
  EXPECT_EQ(server_->find("r2"), nullptr);
}

TEST_F(ServerRouterTest, MessageForARobotWithoutSessionIsAnsweredOncePerSecondAndCounted) {
  server_->on_measurement("ghost", odometry(1, 0.0));
  server_->on_measurement("ghost", odometry(2, 0.0));
  const auto s = sink_.wait_status("ghost", [](const auto& st) { return st.state == SessionState::kNoSession; });
  ASSERT_TRUE(s.has_value());
  EXPECT_NE(s->last_error.find("no session for robot 'ghost': message on locd/odometry ignored"), std::string::npos);
  EXPECT_NE(s->last_error.find("send a session request on locd/session_request"), std::string::npos);
  EXPECT_EQ(server_->messages_without_session(), 2u);
  int reports = 0;
  sink_.wait_for([&](const auto& statuses, const auto&) {
    reports = 0;
    for (const auto& st : statuses) reports += st.robot_id == "ghost";
    return true;
  });
  EXPECT_EQ(reports, 1);
}

TEST_F(ServerRouterTest, SwitchAtRunTimeHandsOverThePoseAndAFailedSwitchKeepsThePlugin) {
  ASSERT_TRUE(request("r3", 1, "fixture_odometry", "plugin: fixture_odometry\n").request_ok);
  PoseEstimate initial;
  initial.pose.translation() = Eigen::Vector3d(10.0, 0.0, 0.0);
  server_->on_initial_pose("r3", initial);
  server_->on_measurement("r3", odometry(100, 3.0));  // anchored at the initial pose: map x = 10
  ASSERT_TRUE(sink_.wait_for([](const auto&, const auto& outputs) { return !outputs.empty() && outputs.back().result.estimate; }));
  EXPECT_NEAR(sink_.outputs().back().result.estimate->pose.translation().x(), 10.0, 1e-9);

  // Failing switch: configure throws. The old plugin keeps running.
  auto s = request("r3", 2, "", "plugin: broken_configure_throws\n");
  EXPECT_FALSE(s.request_ok);
  EXPECT_EQ(s.state, SessionState::kRunning);
  EXPECT_EQ(s.plugin, "fixture_odometry");
  EXPECT_NE(s.message.find("configure of broken_configure_throws failed on purpose"), std::string::npos) << s.message;

  // Good switch to a new fixture instance: it starts from the handed-over pose x = 10 and adds
  // odometry motion from there (odometry x 3 -> 5 gives map x 12).
  s = request("r3", 3, "", "plugin: fixture_odometry\nparams: {position_stddev: 0.5}\n");
  EXPECT_TRUE(s.request_ok) << s.message;
  server_->on_measurement("r3", odometry(200, 3.0));
  server_->on_measurement("r3", odometry(300, 5.0));
  ASSERT_TRUE(sink_.wait_for([](const auto&, const auto& outputs) {
    return !outputs.empty() && outputs.back().result.estimate && outputs.back().result.estimate->header.stamp_ns == 300;
  }));
  const auto last = sink_.outputs().back().result.estimate;
  EXPECT_NEAR(last->pose.translation().x(), 12.0, 1e-9);
  EXPECT_NEAR(last->covariance(0, 0), 0.25, 1e-12);  // the new instance's stddev 0.5
  const auto counters = server_->find("r3")->status().counters;
  EXPECT_EQ(counters.received, 4u);  // the initial pose and three odometry messages
  EXPECT_EQ(counters.used, 4u);
  EXPECT_EQ(counters.updates, 3u);
}

TEST_F(ServerRouterTest, BadInputForASessionIsCountedAndNamed) {
  ASSERT_TRUE(request("r4", 1, "", "plugin: fixture_odometry\n").request_ok);
  server_->on_bad_input("r4", "locd/scan", "scan: 9000 beams exceed the limit max_scan_beams = 8192");
  const auto s = server_->find("r4")->status();
  EXPECT_EQ(s.counters.received, 1u);
  EXPECT_EQ(s.counters.rejected, 1u);
  EXPECT_EQ(s.last_error, "rejected message on locd/scan: scan: 9000 beams exceed the limit max_scan_beams = 8192");
}

TEST_F(ServerRouterTest, StopEndsTheSession) {
  ASSERT_TRUE(request("r5", 1, "", "plugin: fixture_odometry\n").request_ok);
  server_->on_session_request({"r5", 2, true, "", ""});
  ASSERT_TRUE(sink_.wait_status("r5", [](const auto& s) { return s.state == SessionState::kStopped; }));
  EXPECT_EQ(server_->find("r5"), nullptr);
}

// Rate limits (request_limits, defaults: session requests 1/s with a burst of 10, initial poses
// 5/s with 10): a robot flooding the server with requests and initial poses gets its burst and
// its rate, the rest is dropped and counted; another robot's session runs on untouched.
TEST_F(ServerRouterTest, AFloodOfRequestsIsCutToTheRobotsRateAndTheOtherRobotRunsOn) {
  ASSERT_TRUE(request("quiet", 1, "", "plugin: fixture_odometry\n").request_ok);
  const RequestLimits limits;
  const auto& requests = limits.of(RequestKind::kSessionRequest);
  const auto& poses = limits.of(RequestKind::kInitialPose);
  constexpr int kRequests = 2000, kPoses = 500, kOdometry = 40;
  const auto start = std::chrono::steady_clock::now();
  for (int i = 1; i <= kRequests; ++i) {
    server_->on_session_request({"flooder", static_cast<uint64_t>(i), false, "", "plugin: fixture_odometry\n"});
    if (i % (kRequests / kOdometry) == 0) {
      // The quiet robot's odometry, each used before the next is sent (as at its own rate).
      server_->on_measurement("quiet", odometry(i, 0.001 * i));
      EXPECT_TRUE(sink_.wait_for([i](const auto&, const auto& outputs) {
        for (const auto& o : outputs) {
          if (o.robot_id == "quiet" && o.result.estimate && o.result.estimate->header.stamp_ns == i) return true;
        }
        return false;
      })) << "no pose for the quiet robot's odometry at " << i;
    }
  }
  const double requests_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const uint64_t requests_throttled = server_->requests_throttled();
  EXPECT_LE(requests_throttled, kRequests - requests.burst);
  EXPECT_GE(requests_throttled, kRequests - requests.burst - 1 - requests.per_s * requests_s);

  ASSERT_TRUE(sink_.wait_status("flooder", [](const auto& s) { return s.state == SessionState::kRunning; }));
  const auto poses_start = std::chrono::steady_clock::now();
  for (int i = 0; i < kPoses; ++i) server_->on_initial_pose("flooder", PoseEstimate{});
  const double poses_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - poses_start).count();
  const uint64_t poses_throttled = server_->requests_throttled() - requests_throttled;
  EXPECT_LE(poses_throttled, kPoses - poses.burst);
  EXPECT_GE(poses_throttled, kPoses - poses.burst - 1 - poses.per_s * poses_s);
  // Throttled with a session: on the robot's status (the requests, from when the session existed),
  // naming the limit and its key.
  const auto flooder = server_->find("flooder")->status();
  EXPECT_GE(flooder.counters.throttled, poses_throttled);
  EXPECT_LE(flooder.counters.throttled, poses_throttled + requests_throttled);
  EXPECT_NE(flooder.last_error.find("initial pose of robot 'flooder' dropped: over the robot's limit of 5 a second "
                                    "(burst 10), request_limits.initial_poses in the server config"),
            std::string::npos)
      << flooder.last_error;
  EXPECT_EQ(flooder.counters.received, kPoses - poses_throttled);  // the initial poses let through
  // The quiet robot: every odometry message used, its session never restarted or throttled.
  const auto quiet = server_->find("quiet")->status();
  EXPECT_EQ(quiet.request_id, 1u);
  EXPECT_EQ(quiet.counters.used, static_cast<uint64_t>(kOdometry));
  EXPECT_EQ(quiet.counters.throttled, 0u);
  EXPECT_EQ(quiet.counters.dropped, 0u);
  EXPECT_EQ(quiet.counters.rejected, 0u) << quiet.last_error;
}

// A session request over the robot's limit is answered (request_ok false, naming the limit), so a
// robot's client need not wait out its timeout; the running session carries on.
TEST_F(ServerRouterTest, ARequestOverTheLimitIsAnsweredAsRefusedAndTheSessionRunsOn) {
  const std::string config = "plugin: fixture_odometry\n";
  ASSERT_TRUE(request("eager", 1, "", config).request_ok);
  uint64_t id = 1;
  while (server_->requests_throttled() == 0 && id < 1000) server_->on_session_request({"eager", ++id, false, "", config});
  ASSERT_EQ(server_->requests_throttled(), 1u);
  const auto answer = sink_.wait_status("eager", [id](const SessionStatusReport& s) { return s.request_id == id; });
  ASSERT_TRUE(answer.has_value());
  EXPECT_FALSE(answer->request_ok);
  EXPECT_NE(answer->message.find("session request " + std::to_string(id) +
                                 " of robot 'eager' dropped: over the robot's limit of 1 a second (burst 10)"),
            std::string::npos)
      << answer->message;
  EXPECT_EQ(answer->counters.throttled, 1u);
  EXPECT_NE(server_->find("eager"), nullptr);
  ASSERT_TRUE(sink_.wait_status("eager", [id](const SessionStatusReport& s) {
    return s.request_id == id - 1 && s.state == SessionState::kRunning;
  }));
}

// One writer's participant naming many robots (an operator, or anyone in plain mode) gets its
// own budget of session requests across them (here 1 a second, burst 5); a robot of another
// participant is served as before.
TEST_F(ServerRouterTest, AParticipantNamingManyRobotsIsLimitedAcrossThemAndOthersAreServed) {
  server_->shutdown();
  config_.request_limits.session_requests_per_participant = {1.0, 5.0};
  server_ = std::make_unique<Server>(config_, catalog_, sink_, logger_);
  const std::string config = "plugin: fixture_odometry\n";
  constexpr int kRobots = 40;
  const auto start = std::chrono::steady_clock::now();
  std::string first_dropped;
  for (int i = 0; i < kRobots; ++i) {
    server_->on_session_request({"many_" + std::to_string(i), 1, false, "", config, "p1"});
    if (first_dropped.empty() && server_->requests_throttled() == 1) first_dropped = "many_" + std::to_string(i);
  }
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LE(server_->requests_throttled(), kRobots - 5u);
  EXPECT_GE(static_cast<double>(server_->requests_throttled()), kRobots - 5 - 1 - elapsed_s);
  // The first dropped one is answered, naming the participant's limit.
  const auto answer = sink_.wait_status(first_dropped, [](const SessionStatusReport& s) { return !s.request_ok; });
  ASSERT_TRUE(answer.has_value());
  EXPECT_EQ(answer->request_id, 1u);
  EXPECT_NE(answer->message.find("session request 1 of robot '" + first_dropped +
                                 "' dropped: its writer's participant p1 is over its "
                                 "limit of 1 a second (burst 5) across the robots it names, "
                                 "request_limits.session_requests_per_participant in the server config"),
            std::string::npos)
      << answer->message;
  EXPECT_TRUE(request("own", 1, "", config, "p2").request_ok);
}

}  // namespace

namespace {

// A server's loop (rebalance, which writes its heartbeat) stalled for longer than the fleet's
// silence limit while another server knew it: the other may have taken its robots over, so every
// output waits until it has heard the fleet again; a lone server has no one to hear.
TEST_F(ServerRouterTest, AServerStalledAmongOthersWithholdsItsOutputsUntilItHasHeardThemAgain) {
  server_->rebalance();
  std::this_thread::sleep_for(std::chrono::milliseconds(600));  // a stall, alone
  EXPECT_FALSE(server_->outputs_withheld()) << "a lone server withheld its outputs";
  server_->on_server_alive({"other", 1.0, ""});
  server_->rebalance();
  std::this_thread::sleep_for(std::chrono::milliseconds(600));  // a stall, with another server
  EXPECT_TRUE(server_->outputs_withheld());
  server_->rebalance();  // the loop runs again: it withholds until it has heard the fleet again
  EXPECT_TRUE(server_->outputs_withheld());
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(1500);
  while (std::chrono::steady_clock::now() < until) {
    server_->on_server_alive({"other", 1.0, ""});
    server_->rebalance();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  server_->rebalance();
  EXPECT_FALSE(server_->outputs_withheld());
}

}  // namespace
