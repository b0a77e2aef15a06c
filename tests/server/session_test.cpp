// Session semantics with real plugin worker processes (locd-worker) running the fixture plugins
// of tests/broken_plugins: stamp order, drop-oldest, stamps going backwards, one request at a time,
// the pose handed over on a switch (following the odometry), a failed switch keeping the old
// plugin, and what happens when a plugin's worker crashes, exits, hangs or lies: the session
// restarts it from the robot's pose with backoff, gives up after max_failures, and refuses
// unusable estimates. Outputs are observed through a recording OutputSink.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <set>
#include <signal.h>
#include <thread>

#include "test_plugin_index.hpp"
#include "locd/server/session.hpp"
#include "recording_sink.hpp"

namespace {

using namespace locd;
using namespace locd::server;
using locd::server::test::PublishedOutputs;
using locd::server::test::RecordingSink;

Odometry odometry(int64_t stamp, double x = 0.0) {
  Odometry o;
  o.header.stamp_ns = stamp;
  o.pose.translation() = Eigen::Vector3d(x, 0.0, 0.0);
  return o;
}

LaserScan scan(int64_t stamp, float first_range = 1.0f) {
  LaserScan s;
  s.header.stamp_ns = stamp;
  s.range_max = 10.0f;
  s.angle_increment = 0.01f;
  s.ranges = {first_range};
  return s;
}

PoseEstimate pose_at(double x, double y, int64_t stamp = 1) {
  PoseEstimate p;
  p.header.stamp_ns = stamp;
  p.pose.translation() = Eigen::Vector3d(x, y, 0.0);
  return p;
}

const std::string kFixture = "plugin: fixture_odometry\n";
std::string faulty(const std::string& params) { return "plugin: faulty\nparams: {" + params + "}\n"; }

class SessionTest : public ::testing::Test {
 protected:
  SessionTest() : catalog_(locd::server::test::plugin_index(LOCD_BROKEN_PLUGIN_DIR)) {}

  std::shared_ptr<Session> make(size_t depth, FailurePolicy failures = {}, double update_deadline_s = 10.0) {
    WorkerSettings settings;
    settings.executable = LOCD_WORKER_EXECUTABLE;
    settings.update_deadline_s = update_deadline_s;
    settings.memory_limit_mb = 512;
    workers_ = std::make_unique<PluginWorkers>(settings, Limits{}, logger_);
    pool_ = std::make_unique<WorkerPool>(2);
    environment_ = std::make_unique<SessionEnvironment>(
        SessionEnvironment{*workers_, *pool_, sink_, depth, failures, worker::ConfigureRequest{}, nullptr});
    return std::make_shared<Session>("robot", *environment_, [this](LogLevel level, const std::string& line) {
      std::lock_guard<std::mutex> lock(log_mutex_);
      log_.emplace_back(level, line);
    });
  }
  std::vector<std::string> warnings() {
    std::lock_guard<std::mutex> lock(log_mutex_);
    std::vector<std::string> lines;
    for (const auto& [level, line] : log_) {
      if (level == LogLevel::kWarning) lines.push_back(line);
    }
    return lines;
  }
  void request(Session& session, const std::string& yaml, uint64_t request_id) {
    const uint64_t generation = session.begin_request(request_id);
    const PluginConfig config = split_plugin_config(yaml, "test");
    session.start(generation, request_id, catalog_.require(config.plugin), PluginConfigText{yaml, "test", {}}, "test");
  }
  // Starts a plugin and waits until the session reports it running.
  void install(Session& session, const std::string& yaml, uint64_t request_id) {
    request(session, yaml, request_id);
    const std::string plugin = split_plugin_config(yaml, "test").plugin;
    ASSERT_TRUE(sink_.wait_status("robot", [&](const SessionStatusReport& s) {
      return s.request_id == request_id && s.plugin == plugin && s.state == SessionState::kRunning;
    })) << "plugin " << plugin << " did not start";
  }
  bool wait_counted(Session& session, uint64_t handled) {
    return sink_.wait_for([&](const auto&, const auto&) {
      const auto c = session.status().counters;
      return c.used + c.rejected >= handled;
    });
  }
  // The session counts an update before it publishes its outputs (it publishes outside its lock),
  // so a test that reads the outputs waits for them, not for the counters.
  bool wait_outputs(size_t count, int64_t below = 1'000'000'000) {
    return sink_.wait_for([&](const auto&, const auto& outputs) {
      size_t n = 0;
      for (const auto& o : outputs) n += o.header.stamp_ns < below;
      return n >= count;
    });
  }
  // Stamps of the outputs published after configure (header = measurement stamp), in order.
  std::vector<int64_t> output_stamps(int64_t below = 1'000'000'000) {
    std::vector<int64_t> stamps;
    for (const auto& o : sink_.outputs()) {
      if (o.header.stamp_ns < below) stamps.push_back(o.header.stamp_ns);
    }
    return stamps;
  }
  std::vector<PoseEstimate> estimates() {
    std::vector<PoseEstimate> out;
    for (const auto& o : sink_.outputs()) {
      if (o.result.estimate) out.push_back(*o.result.estimate);
    }
    return out;
  }
  bool wait_estimates(size_t count) {
    return sink_.wait_for([&](const auto&, const auto& outputs) {
      size_t n = 0;
      for (const auto& o : outputs) n += o.result.estimate.has_value();
      return n >= count;
    });
  }
  void TearDown() override {
    if (workers_) workers_->shutdown(std::chrono::milliseconds(500));
    if (pool_) pool_->shutdown();
  }

  PluginIndex catalog_;
  Logger logger_{LogLevel::kError};
  RecordingSink sink_;
  std::unique_ptr<PluginWorkers> workers_;
  std::unique_ptr<WorkerPool> pool_;
  std::unique_ptr<SessionEnvironment> environment_;
  std::mutex log_mutex_;
  std::vector<std::pair<LogLevel, std::string>> log_;
};

TEST_F(SessionTest, MeasurementsRunInStampOrderAcrossKinds) {
  auto session = make(16);
  // Queued before the plugin runs: arrival order 300, 100, 200 (two kinds).
  session->push(odometry(300));
  session->push(scan(100));
  session->push(scan(200));
  install(*session, kFixture, 1);
  ASSERT_TRUE(wait_counted(*session, 3));
  ASSERT_TRUE(wait_outputs(3));
  EXPECT_EQ(output_stamps(), (std::vector<int64_t>{100, 200, 300}));
}

TEST_F(SessionTest, FullQueueDropsTheOldestAndCountsIt) {
  auto session = make(3);
  for (int64_t stamp = 1; stamp <= 5; ++stamp) session->push(odometry(stamp));
  EXPECT_EQ(session->status().counters.dropped, 2u);
  install(*session, kFixture, 1);
  ASSERT_TRUE(wait_counted(*session, 3));
  const auto c = session->status().counters;
  EXPECT_EQ(c.received, 5u);
  EXPECT_EQ(c.used, 3u);
  EXPECT_EQ(c.dropped, 2u);
  EXPECT_EQ(c.updates, 3u);
  ASSERT_TRUE(wait_outputs(3));
  EXPECT_EQ(output_stamps(), (std::vector<int64_t>{3, 4, 5}));
}

TEST_F(SessionTest, FullQueueDropsTheOldestSensorFrameBeforeAnyOdometry) {
  auto session = make(3);
  session->push(odometry(1));
  session->push(scan(2));
  session->push(odometry(3));
  session->push(scan(4));      // full: scan 2 goes, odometry 1 stays
  session->push(odometry(5));  // full: scan 4 goes
  session->push(odometry(6));  // only odometry left: the oldest, 1, goes
  EXPECT_EQ(session->status().counters.dropped, 3u);
  install(*session, kFixture, 1);
  ASSERT_TRUE(wait_counted(*session, 3));
  ASSERT_TRUE(wait_outputs(3));
  EXPECT_EQ(output_stamps(), (std::vector<int64_t>{3, 5, 6}));
}

TEST_F(SessionTest, StampGoingBackwardsOnAKindIsRejectedAndNamed) {
  auto session = make(16);
  install(*session, kFixture, 1);
  session->push(scan(1300));
  session->push(scan(1200));
  session->push(odometry(1200));  // another kind: its own order
  ASSERT_TRUE(wait_counted(*session, 3));
  const auto status = session->status();
  EXPECT_EQ(status.counters.received, 3u);
  EXPECT_EQ(status.counters.rejected, 1u);
  EXPECT_EQ(status.counters.used, 2u);
  EXPECT_EQ(status.last_error, "stamp going backwards on locd/scan: 1200 < 1300 ns");
}

TEST_F(SessionTest, GapsInAStreamsNumbersAreCountedAsLostInTransit) {
  auto session = make(16);
  install(*session, kFixture, 1);
  auto numbered = [](int64_t stamp, uint64_t sequence) {
    Odometry o = odometry(stamp);
    o.header.sequence = sequence;
    return o;
  };
  session->push(numbered(100, 1));
  session->push(numbered(200, 2));
  session->push(numbered(300, 5));  // 3 and 4 never arrived
  LaserScan s = scan(310);
  s.header.sequence = 7;  // another stream: its own numbers (the first one seen counts nothing)
  session->push(s);
  session->push(numbered(400, 1));  // a new writer (the robot restarted): counted from here
  session->push(numbered(500, 3));
  session->push(odometry(600));     // not numbered: not counted
  ASSERT_TRUE(wait_counted(*session, 7));
  const auto c = session->status().counters;
  EXPECT_EQ(c.lost, 3u);
  EXPECT_EQ(c.lost_by_kind[0], 3u);  // odometry
  EXPECT_EQ(c.lost_by_kind[2], 0u);  // scan
  EXPECT_EQ(c.received, 7u);
}

TEST_F(SessionTest, PluginInputErrorIsRejectedAndTheSessionGoesOn) {
  auto session = make(16);
  install(*session, kFixture, 1);
  session->push(scan(10, -1.0f));
  session->push(odometry(20));
  ASSERT_TRUE(wait_counted(*session, 2));
  const auto status = session->status();
  EXPECT_EQ(status.counters.rejected, 1u);
  EXPECT_EQ(status.counters.used, 1u);
  EXPECT_EQ(status.last_error, "locd/scan: scan has no valid return");
  ASSERT_TRUE(wait_estimates(1));
  EXPECT_EQ(estimates().back().header.stamp_ns, 20);
}

TEST_F(SessionTest, TwoProducersAreServedOneRequestAtATimeInStampOrderPerKind) {
  auto session = make(10000);
  install(*session, faulty("work_ms: 0.2"), 1);
  // Two producers (like two listener threads) push interleaved stamps of two kinds.
  std::thread odometry_thread([&] { for (int64_t i = 0; i < 200; ++i) session->push(odometry(2 * i + 2)); });
  std::thread scan_thread([&] { for (int64_t i = 0; i < 200; ++i) session->push(scan(2 * i + 3)); });
  odometry_thread.join();
  scan_thread.join();
  ASSERT_TRUE(wait_counted(*session, 400));
  EXPECT_EQ(session->status().counters.used, 400u);
  ASSERT_TRUE(wait_estimates(200));
  std::vector<int64_t> odometry_stamps;
  for (const auto& e : estimates()) odometry_stamps.push_back(e.header.stamp_ns);
  ASSERT_EQ(odometry_stamps.size(), 200u);
  EXPECT_TRUE(std::is_sorted(odometry_stamps.begin(), odometry_stamps.end()));
}

TEST_F(SessionTest, SwitchHandsTheRobotsPoseToTheNewPluginFollowingTheOdometry) {
  auto session = make(16);
  install(*session, kFixture, 1);
  session->set_pose(pose_at(10.0, 2.0));
  session->push(odometry(1000, 1.0));  // anchors the set pose: x = 10
  session->push(odometry(4000, 4.0));  // x = 13
  ASSERT_TRUE(wait_estimates(2));
  EXPECT_NEAR(estimates().back().pose.translation().x(), 13.0, 1e-9);
  install(*session, faulty(""), 2);
  // The new plugin takes the pose at its first odometry: map_from_odom of the last estimate
  // carried to x = 5, so it continues at 14 where the old plugin would have been.
  session->push(odometry(5000, 5.0));
  ASSERT_TRUE(wait_estimates(3));
  const auto last = estimates().back();
  EXPECT_NEAR(last.pose.translation().x(), 14.0, 1e-9);
  EXPECT_NEAR(last.pose.translation().y(), 2.0, 1e-9);
  EXPECT_EQ(session->status().plugin, "faulty");
}

TEST_F(SessionTest, FailedSwitchKeepsTheOldPluginAndReportsTheError) {
  auto session = make(16);
  install(*session, kFixture, 1);
  request(*session, "plugin: fixture_odometry\nparams: {position_stddev: -1}\n", 2);
  ASSERT_TRUE(sink_.wait_status("robot", [](const auto& s) { return s.request_id == 2 && !s.request_ok; }));
  const auto status = session->status();
  EXPECT_EQ(status.state, SessionState::kRunning);
  EXPECT_EQ(status.plugin, "fixture_odometry");
  EXPECT_NE(status.message.find("position_stddev"), std::string::npos) << status.message;
  session->push(odometry(10));
  ASSERT_TRUE(wait_counted(*session, 1));
  ASSERT_TRUE(wait_outputs(1));
  EXPECT_EQ(output_stamps(), (std::vector<int64_t>{10}));
}

TEST_F(SessionTest, SupersededRequestIsNotInstalled) {
  auto session = make(16);
  const uint64_t g1 = session->begin_request(1);
  const uint64_t g2 = session->begin_request(2);
  session->start(g2, 2, catalog_.require("faulty"), PluginConfigText{faulty(""), "test", {}}, "test");
  session->start(g1, 1, catalog_.require("fixture_odometry"), PluginConfigText{kFixture, "test", {}}, "test");
  session->push(odometry(1));
  ASSERT_TRUE(wait_counted(*session, 1));
  EXPECT_EQ(session->status().plugin, "faulty");
  ASSERT_TRUE(wait_outputs(1));
  EXPECT_EQ(sink_.outputs().back().plugin, "faulty");
}

TEST_F(SessionTest, StopReleasesThePluginAndRefusesFurtherMessages) {
  auto session = make(16);
  install(*session, kFixture, 1);
  ASSERT_EQ(workers_->worker_count(), 1u);
  session->stop(2, "stopped by request 2");
  ASSERT_TRUE(sink_.wait_status("robot", [](const auto& s) { return s.state == SessionState::kStopped; }));
  EXPECT_FALSE(session->push(odometry(1)));
  // Its last instance released, the worker process ends.
  for (int i = 0; i < 500 && workers_->worker_count() > 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(workers_->worker_count(), 0u);
}

TEST_F(SessionTest, InitialPoseReachesThePluginAheadOfQueuedMeasurements) {
  auto session = make(16);
  install(*session, kFixture, 1);
  session->set_pose(pose_at(7.0, -1.0));
  session->push(odometry(1));
  ASSERT_TRUE(wait_estimates(1));
  EXPECT_NEAR(estimates().back().pose.translation().x(), 7.0, 1e-9);
  EXPECT_EQ(session->status().initial_pose_stamp_ns, 1);
}

TEST_F(SessionTest, ANewRequestAcceptsARestartedRobotsClock) {
  auto session = make(16);
  install(*session, kFixture, 1);
  session->push(odometry(5000));
  ASSERT_TRUE(wait_counted(*session, 1));
  install(*session, kFixture, 2);
  session->push(odometry(10));  // the robot restarted: its clock begins again
  ASSERT_TRUE(wait_counted(*session, 2));
  EXPECT_EQ(session->status().counters.rejected, 0u);
  EXPECT_EQ(session->status().counters.used, 2u);
}

// The server's state file seeds the session (a server restart); the robot, alive, sends a newer
// initial pose before any sensor message (as locsim live does: it waits for the pose to be taken
// first). The pose is taken at once: the resumed pose, which waits for the robot's next message,
// does not hold it back.
TEST_F(SessionTest, ANewerInitialPoseWinsOverTheSavedStateAndIsTakenAtOnce) {
  auto session = make(16);
  ResumeState saved{pose_at(50.0, 50.0, 1000), std::nullopt, "fixture_odometry", 1, false, "", 0};
  session->seed(saved);
  install(*session, kFixture, 1);  // the same request: the robot's own, replayed
  session->set_pose(pose_at(7.0, -1.0, 2000));
  ASSERT_TRUE(sink_.wait_status("robot", [](const auto& s) { return s.initial_pose_stamp_ns == 2000; }))
      << "the initial pose was not taken before any sensor message";
  session->push(odometry(3000));
  ASSERT_TRUE(wait_estimates(1));
  EXPECT_NEAR(estimates().back().pose.translation().x(), 7.0, 1e-9);
  const auto status = session->status();
  EXPECT_EQ(status.counters.rejected, 0u);
  EXPECT_EQ(status.counters.received, status.counters.used + status.counters.held);
}

// A replayed initial pose older than the saved state is refused as stale; the session resumes
// from the saved pose at the robot's next message, and says so while it waits for it.
TEST_F(SessionTest, AnOlderInitialPoseIsRefusedAndTheResumedPoseWaitsNamedOnTheStatus) {
  auto session = make(16);
  ResumeState saved{pose_at(50.0, 50.0, 1000), std::nullopt, "fixture_odometry", 1, false, "", 0};
  session->seed(saved);
  install(*session, kFixture, 1);
  session->set_pose(pose_at(7.0, -1.0, 500));
  ASSERT_TRUE(sink_.wait_status("robot", [](const auto& s) { return s.counters.rejected == 1; }));
  EXPECT_NE(session->status().last_error.find("older than the pose resumed"), std::string::npos);
  session->save_map(9);  // a control message behind the waiting resumed pose is not held with it
  ASSERT_TRUE(sink_.wait_status("robot", [](const auto& s) { return s.request_id == 9; }));
  session->push(odometry(3000));
  ASSERT_TRUE(wait_estimates(1));
  EXPECT_NEAR(estimates().back().pose.translation().x(), 50.0, 1e-9);
}

// A robot that started again sends a new request: the saved state belongs to the old one, so the
// plugin starts as the new request says (here: from its own origin), and any initial pose the
// robot sends is its own, whatever its stamp.
TEST_F(SessionTest, ANewRequestFromARobotThatStartedAgainDropsTheSavedState) {
  auto session = make(16);
  ResumeState saved{pose_at(50.0, 50.0, 5'000'000), std::nullopt, "fixture_odometry", 1, false, "", 0};
  session->seed(saved);
  install(*session, kFixture, 2);
  session->push(odometry(1000, 1.0));
  ASSERT_TRUE(wait_estimates(1));
  EXPECT_NEAR(estimates().back().pose.translation().x(), 0.0, 1e-9);  // the plugin's own start, not 50
  session->set_pose(pose_at(3.0, 0.0, 10));  // stamped before the saved pose: still the robot's own
  session->push(odometry(2000, 2.0));
  ASSERT_TRUE(wait_estimates(2));
  EXPECT_NEAR(estimates().back().pose.translation().x(), 3.0, 1e-9);
  EXPECT_EQ(session->status().counters.rejected, 0u);
}

// What the session holds is counted and named: here messages wait for a plugin still being
// configured (it takes a while), then all are used.
TEST_F(SessionTest, HeldMessagesAreCountedAndTheirWaitIsNamed) {
  auto session = make(16);
  request(*session, faulty("fault: none, work_ms: 300"), 1);
  session->push(odometry(1000));
  session->push(odometry(2000));
  const auto held = session->status();
  EXPECT_EQ(held.counters.received, held.counters.used + held.counters.dropped + held.counters.rejected +
                                        held.counters.held);
  EXPECT_GE(held.counters.held, 1u);
  EXPECT_FALSE(held.waiting_for.empty());
  ASSERT_TRUE(wait_counted(*session, 2));
  const auto done = session->status();
  EXPECT_EQ(done.counters.held, 0u);
  EXPECT_EQ(done.waiting_for, "");
  EXPECT_EQ(done.counters.received, done.counters.used);
}

// Forty robots start at once with one session per worker: forty workers, each with one
// instance (a slot is taken as it is found, and a new worker comes with its first slot taken).
TEST(PluginWorkers, SessionsPerWorkerHoldsWhenManySessionsStartAtOnce) {
  struct Owner : InstanceOwner {
    void on_reply(uint64_t, worker::Reply) override {}
    void on_log(uint64_t, const worker::LogLine&) override {}
    void on_lost(uint64_t, const WorkerLoss&) override {}
  };
  constexpr int kSessions = 40;
  Logger logger(LogLevel::kError);
  WorkerSettings settings;
  settings.executable = LOCD_WORKER_EXECUTABLE;
  settings.sessions_per_worker = 1;
  PluginWorkers workers(settings, Limits{}, logger);
  const PluginIndex catalog = locd::server::test::plugin_index(LOCD_BROKEN_PLUGIN_DIR);
  const auto library = catalog.require("fixture_odometry");
  auto owner = std::make_shared<Owner>();
  std::vector<uint64_t> instances(kSessions, 0);
  std::vector<std::thread> starting;
  std::atomic<bool> go{false};
  for (int i = 0; i < kSessions; ++i) {
    starting.emplace_back([&, i] {
      while (!go) std::this_thread::yield();
      instances[i] = workers.create_instance(library, owner);
    });
  }
  go = true;
  for (auto& t : starting) t.join();
  std::set<pid_t> pids;
  for (const uint64_t instance : instances) pids.insert(workers.pid_of(instance));
  EXPECT_EQ(pids.size(), static_cast<size_t>(kSessions));
  EXPECT_EQ(workers.worker_count(), static_cast<size_t>(kSessions));
  EXPECT_EQ(pids.count(0), 0u);
  workers.shutdown(std::chrono::milliseconds(1000));
}

TEST_F(SessionTest, ARejectionFloodIsCountedInFullAndLoggedWithinItsBudget) {
  auto session = make(16);
  install(*session, kFixture, 1);
  session->push(odometry(1000));
  constexpr int kBad = 200;
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < kBad; ++i) session->push(odometry(1));  // stamp going backwards
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(sink_.wait_status("robot", [](const SessionStatusReport& s) { return s.counters.rejected == kBad; }));
  const auto lines = warnings();
  // The budget per started one-second window, however long the flood took on this machine.
  const auto windows = static_cast<size_t>(std::ceil(seconds)) + 1;
  ASSERT_GE(lines.size(), static_cast<size_t>(Session::kRejectionLinesPerSecond));
  EXPECT_LE(lines.size(), windows * Session::kRejectionLinesPerSecond);
  EXPECT_LT(lines.size(), static_cast<size_t>(kBad));
  EXPECT_NE(lines[0].find("stamp going backwards on locd/odometry: 1 < 1000 ns"), std::string::npos) << lines[0];
  EXPECT_NE(lines[Session::kRejectionLinesPerSecond - 1].find("further rejections this second are counted, not logged"),
            std::string::npos);
}

TEST_F(SessionTest, MessagesQueuedForAFailedFirstRequestAreCountedAsDropped) {
  auto session = make(16);
  for (int64_t stamp = 1; stamp <= 3; ++stamp) session->push(odometry(stamp));
  const uint64_t generation = session->begin_request(1);
  EXPECT_FALSE(session->fail_request(generation, 1, "plugin 'nope' not found"));
  EXPECT_TRUE(session->abandon_if_idle(generation));
  const auto status = session->status();
  EXPECT_EQ(status.counters.received, 3u);
  EXPECT_EQ(status.counters.dropped, 3u);
  EXPECT_EQ(status.state, SessionState::kError);
}

TEST_F(SessionTest, StopCountsTheDiscardedQueueAsDropped) {
  auto session = make(16);
  for (int64_t stamp = 1; stamp <= 5; ++stamp) session->push(odometry(stamp));  // plugin still starting
  session->stop(2, "stopped by request 2");
  ASSERT_TRUE(sink_.wait_status("robot", [](const auto& s) { return s.state == SessionState::kStopped; }));
  const auto c = session->status().counters;
  EXPECT_EQ(c.received, 5u);
  EXPECT_EQ(c.dropped, 5u);
  EXPECT_EQ(c.used, 0u);
}

// ------------------------------------------------------------------------------ faults

struct FaultCase {
  std::string fault;
  std::string cause;  // what the status names
  double update_deadline_s = 10.0;
};

void PrintTo(const FaultCase& c, std::ostream* out) { *out << c.fault; }

class SessionFaultTest : public SessionTest, public ::testing::WithParamInterface<FaultCase> {};

// The worker dies (or is killed) on the 4th odometry: the status names the plugin, the cause and
// the message; the session restarts the plugin from the robot's pose and goes on, and the message
// it died on is counted as rejected, never given again.
TEST_P(SessionFaultTest, AFailedWorkerIsNamedAndTheSessionResumesFromTheRobotsPose) {
  FailurePolicy failures;
  failures.backoff_initial_s = 0.05;
  auto session = make(64, failures, GetParam().update_deadline_s);
  install(*session, faulty("fault: " + GetParam().fault + ", after_updates: 3"), 1);
  session->set_pose(pose_at(10.0, 2.0));
  for (int k = 1; k <= 3; ++k) session->push(odometry(k * 1000, 0.1 * k));
  ASSERT_TRUE(wait_estimates(3));
  session->push(odometry(4000, 0.4));  // strikes
  const auto failed = sink_.wait_status("robot", [](const auto& s) { return s.failures == 1; });
  ASSERT_TRUE(failed);
  EXPECT_EQ(failed->state, SessionState::kRestarting) << failed->last_error;
  EXPECT_NE(failed->last_error.find("plugin 'faulty' (worker pid "), std::string::npos) << failed->last_error;
  EXPECT_NE(failed->last_error.find(GetParam().cause), std::string::npos) << failed->last_error;
  EXPECT_NE(failed->last_error.find("the update of locd/odometry stamped 0.000004 s"), std::string::npos)
      << failed->last_error;
  ASSERT_TRUE(sink_.wait_status("robot", [](const auto& s) { return s.state == SessionState::kRunning && s.failures == 1; }));
  // The restarted plugin (a fresh one: it strikes again only after 3 more updates) resumes where
  // the robot is, not at its initial pose: the set pose anchored x = 10 at odometry 0.1, the
  // last estimate was 10.2 at odometry 0.3, so at odometry 0.5 the robot is at 10.4, as the
  // plugin would have said had it never failed.
  session->push(odometry(5000, 0.5));
  ASSERT_TRUE(wait_estimates(4));
  EXPECT_NEAR(estimates().back().pose.translation().x(), 10.4, 1e-9);
  EXPECT_NEAR(estimates().back().pose.translation().y(), 2.0, 1e-9);
  const auto c = session->status().counters;
  EXPECT_EQ(c.received, 6u);  // the initial pose and five odometry messages
  EXPECT_EQ(c.rejected, 1u);  // the one it died on
}

INSTANTIATE_TEST_SUITE_P(
    Faults, SessionFaultTest,
    ::testing::Values(FaultCase{"segfault", "was killed by signal 11 (SIGSEGV"},
                      FaultCase{"abort", "was killed by signal 6 (SIGABRT"},
                      FaultCase{"exit", "exited with code 3"},
                      FaultCase{"hang", "did not answer the update of locd/odometry stamped 0.000004 s within 0.5 s", 0.5},
                      FaultCase{"allocate", "ran out of memory (memory_limit_mb = 512)"},
                      FaultCase{"stack_overflow", "was killed by signal 11 (SIGSEGV"},
                      FaultCase{"garbage", "broke the worker protocol"}),
    [](const auto& info) { return info.param.fault; });

TEST_F(SessionTest, APluginThatKeepsFailingIsRestartedWithBackoffThenMarkedFailed) {
  FailurePolicy failures;
  failures.max_failures = 3;
  failures.backoff_initial_s = 0.05;
  failures.backoff_max_s = 0.1;
  auto session = make(64, failures);
  install(*session, faulty("fault: abort"), 1);
  // Each restart dies on the next odometry; the third failure in a row stops the session.
  for (int k = 1; k <= 3; ++k) {
    session->push(odometry(k * 1000));
    ASSERT_TRUE(sink_.wait_status("robot", [&](const auto& s) { return s.failures == static_cast<uint32_t>(k); }));
    if (k < 3) {
      ASSERT_TRUE(sink_.wait_status("robot", [&](const auto& s) {
        return s.state == SessionState::kRunning && s.failures == static_cast<uint32_t>(k);
      }));
    }
  }
  const auto status = sink_.wait_status("robot", [](const auto& s) { return s.state == SessionState::kFailed; });
  ASSERT_TRUE(status);
  EXPECT_NE(status->last_error.find("failed 3 times in a row (max_failures = 3)"), std::string::npos)
      << status->last_error;
  EXPECT_EQ(session->resume_state()->failed, true);
  EXPECT_EQ(session->resume_state()->request_id, 1u);
  // Nothing is sent to a failed session's plugin; a new request starts it again.
  session->push(odometry(9000));
  install(*session, kFixture, 2);
  session->push(odometry(10000));
  ASSERT_TRUE(wait_estimates(1));
}

class SessionLieTest : public SessionTest, public ::testing::WithParamInterface<std::pair<std::string, std::string>> {};

TEST_P(SessionLieTest, AnUnusableEstimateIsRefusedAndTheSessionGoesOn) {
  const auto& [fault, why] = GetParam();
  auto session = make(16);
  install(*session, faulty("fault: " + fault + ", after_updates: 1"), 1);
  session->push(odometry(1000));
  session->push(odometry(2000));  // lies
  session->push(odometry(3000));  // lies too: every update after the first
  ASSERT_TRUE(wait_counted(*session, 3));
  const auto status = session->status();
  EXPECT_EQ(status.counters.rejected, 2u);
  EXPECT_EQ(status.failures, 0u);
  EXPECT_EQ(status.state, SessionState::kRunning);
  EXPECT_NE(status.last_error.find("plugin 'faulty' returned an unusable estimate for the update of locd/odometry"),
            std::string::npos)
      << status.last_error;
  EXPECT_NE(status.last_error.find(why), std::string::npos) << status.last_error;
  EXPECT_EQ(estimates().size(), 1u);  // the lies are not published
}

INSTANTIATE_TEST_SUITE_P(Lies, SessionLieTest,
                         ::testing::Values(std::make_pair(std::string("nan_pose"), std::string("NaN")),
                                           std::make_pair(std::string("bad_covariance"),
                                                          std::string("not positive semi-definite"))),
                         [](const auto& info) { return info.param.first; });

TEST_F(SessionTest, AThrowingPluginIsRejectedWithoutARestart) {
  auto session = make(16);
  install(*session, faulty("fault: throw"), 1);
  session->push(odometry(1000));
  ASSERT_TRUE(wait_counted(*session, 1));
  const auto status = session->status();
  EXPECT_EQ(status.counters.rejected, 1u);
  EXPECT_EQ(status.failures, 0u);
  EXPECT_EQ(status.last_error, "plugin 'faulty' failed on locd/odometry: faulty: thrown on purpose");
}

TEST_F(SessionTest, APluginThatCrashesWhileConfiguringFailsItsRequest) {
  auto session = make(16);
  request(*session, faulty("fault: segfault, fault_in: configure"), 1);
  const auto status = sink_.wait_status("robot", [](const auto& s) { return s.request_id == 1 && !s.request_ok; });
  ASSERT_TRUE(status);
  EXPECT_EQ(status->state, SessionState::kError);
  EXPECT_NE(status->message.find("was killed by signal 11 (SIGSEGV"), std::string::npos) << status->message;
  EXPECT_NE(status->message.find("while handling the configure of plugin 'faulty'"), std::string::npos)
      << status->message;
}

TEST_F(SessionTest, AnotherSessionsCrashRestartsThisOneAtOnceWithoutCountingAFailure) {
  WorkerSettings settings;
  settings.executable = LOCD_WORKER_EXECUTABLE;
  settings.sessions_per_worker = 2;  // both robots in one worker process
  workers_ = std::make_unique<PluginWorkers>(settings, Limits{}, logger_);
  pool_ = std::make_unique<WorkerPool>(2);
  environment_ = std::make_unique<SessionEnvironment>(
      SessionEnvironment{*workers_, *pool_, sink_, 16, FailurePolicy{}, worker::ConfigureRequest{}, nullptr});
  auto victim = std::make_shared<Session>("victim", *environment_, nullptr);
  auto culprit = std::make_shared<Session>("culprit", *environment_, nullptr);
  auto start = [&](Session& s, const std::string& yaml) {
    const uint64_t generation = s.begin_request(1);
    s.start(generation, 1, catalog_.require("faulty"), PluginConfigText{yaml, "test", {}}, "test");
    ASSERT_TRUE(sink_.wait_status(s.robot_id(), [](const auto& st) { return st.state == SessionState::kRunning; }));
  };
  start(*victim, faulty(""));
  start(*culprit, faulty("fault: segfault"));
  EXPECT_EQ(workers_->worker_count(), 1u);
  victim->set_pose(pose_at(3.0, 0.0));
  victim->push(odometry(1000, 1.0));
  ASSERT_TRUE(sink_.wait_for([](const auto&, const auto& outputs) {
    for (const auto& o : outputs) {
      if (o.robot_id == "victim" && o.result.estimate) return true;
    }
    return false;
  }));
  culprit->push(odometry(1000));
  ASSERT_TRUE(sink_.wait_status("culprit", [](const auto& s) { return s.failures == 1; }));
  const auto restarted = sink_.wait_status("victim", [](const auto& s) { return s.state == SessionState::kRestarting; });
  ASSERT_TRUE(restarted);
  EXPECT_EQ(restarted->failures, 0u);
  EXPECT_NE(restarted->last_error.find("another session's request; this one restarts"), std::string::npos)
      << restarted->last_error;
  ASSERT_TRUE(sink_.wait_status("victim", [](const auto& s) { return s.state == SessionState::kRunning; }));
  victim->push(odometry(2000, 2.0));
  ASSERT_TRUE(sink_.wait_for([](const auto&, const auto& outputs) {
    for (const auto& o : outputs) {
      if (o.robot_id == "victim" && o.result.estimate && o.result.estimate->header.stamp_ns == 2000) {
        return std::abs(o.result.estimate->pose.translation().x() - 4.0) < 1e-9;
      }
    }
    return false;
  }));
  victim->stop(2, "done");
  culprit->stop(2, "done");
}

TEST_F(SessionTest, AutomaticPlacementKeepsRobotsAloneUpToTheCapThenSharesTheWorkers) {
  // sessions_per_worker: auto (the default): each robot gets a worker of its own until the plugin
  // has workers_per_plugin of them; later robots join the least-loaded one, and the number of
  // processes (and their wake-ups) stays bounded however large the fleet.
  WorkerSettings settings;
  settings.executable = LOCD_WORKER_EXECUTABLE;
  ASSERT_EQ(settings.sessions_per_worker, WorkerSettings::kAuto);
  settings.workers_per_plugin = 2;
  workers_ = std::make_unique<PluginWorkers>(settings, Limits{}, logger_);
  pool_ = std::make_unique<WorkerPool>(2);
  environment_ = std::make_unique<SessionEnvironment>(
      SessionEnvironment{*workers_, *pool_, sink_, 16, FailurePolicy{}, worker::ConfigureRequest{}, nullptr});
  std::vector<std::shared_ptr<Session>> sessions;
  for (int k = 0; k < 5; ++k) {
    auto s = std::make_shared<Session>("robot" + std::to_string(k), *environment_, nullptr);
    const uint64_t generation = s->begin_request(1);
    s->start(generation, 1, catalog_.require("faulty"), PluginConfigText{faulty(""), "test", {}}, "test");
    ASSERT_TRUE(sink_.wait_status(s->robot_id(), [](const auto& st) { return st.state == SessionState::kRunning; }));
    sessions.push_back(s);
    EXPECT_EQ(workers_->worker_count(), std::min<size_t>(k + 1, 2)) << "after " << k + 1 << " robots";
  }
  for (auto& s : sessions) s->stop(2, "done");
  EXPECT_GE(WorkerSettings{}.auto_worker_cap(), 8u);
}

}  // namespace
