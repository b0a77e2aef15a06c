// Session queue semantics with a recording Localizer (defined here; it tests the queue, it is not
// a shipped plugin): stamp order, drop-oldest, stamps going backwards, serial execution, the pose
// handed over on a plugin switch, and a failed switch keeping the old plugin.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <thread>

#include "locd/server/session.hpp"
#include "recording_sink.hpp"

namespace {

using namespace locd;
using namespace locd::server;
using locd::server::test::RecordingSink;

struct Record {
  std::mutex mutex;
  std::vector<int64_t> stamps;             // measurement stamps in update order
  std::vector<PoseEstimate> poses_set;     // what set_pose received
  std::atomic<int> inside{0};
  std::atomic<int> max_inside{0};
  std::atomic<int> destroyed{0};
};

// Records every call. An odometry update returns an estimate at x = stamp / 1000; a scan whose
// first range is negative is rejected with an InputError.
class RecordingLocalizer : public Localizer {
 public:
  RecordingLocalizer(std::shared_ptr<Record> record, std::chrono::microseconds work = {})
      : record_(std::move(record)), work_(work) {}
  ~RecordingLocalizer() override { ++record_->destroyed; }
  void configure(const PluginContext&, const Params&) override {}
  void set_pose(const PoseEstimate& pose) override {
    std::lock_guard<std::mutex> lock(record_->mutex);
    record_->poses_set.push_back(pose);
  }
  UpdateResult update(const Measurement& m) override {
    const int now_inside = ++record_->inside;
    int seen = record_->max_inside.load();
    while (now_inside > seen && !record_->max_inside.compare_exchange_weak(seen, now_inside)) {
    }
    if (work_.count() > 0) std::this_thread::sleep_for(work_);
    const int64_t stamp = header_of(m).stamp_ns;
    {
      std::lock_guard<std::mutex> lock(record_->mutex);
      record_->stamps.push_back(stamp);
    }
    --record_->inside;
    if (const auto* scan = std::get_if<LaserScan>(&m); scan && !scan->ranges.empty() && scan->ranges[0] < 0) {
      throw InputError("negative range " + std::to_string(scan->ranges[0]));
    }
    UpdateResult result;
    if (std::holds_alternative<Odometry>(m)) {
      PoseEstimate e;
      e.pose.translation() = Eigen::Vector3d(static_cast<double>(stamp) / 1000.0, 0.0, 0.0);
      result.estimate = e;
    }
    return result;
  }

 private:
  std::shared_ptr<Record> record_;
  std::chrono::microseconds work_;
};

// A LocalizerPtr that owns a RecordingLocalizer without a plugin library.
LocalizerPtr recording(std::shared_ptr<Record> record, std::chrono::microseconds work = {}) {
  return LocalizerPtr(new RecordingLocalizer(std::move(record), work), LocalizerDeleter{nullptr});
}

Odometry odometry(int64_t stamp) {
  Odometry o;
  o.header.stamp_ns = stamp;
  return o;
}

LaserScan scan(int64_t stamp, float first_range = 1.0f) {
  LaserScan s;
  s.header.stamp_ns = stamp;
  s.range_max = 10.0f;
  s.angle_increment = 0.01f;
  s.ranges = {first_range, 1.0f};
  return s;
}

class SessionTest : public ::testing::Test {
 protected:
  std::shared_ptr<Session> make(size_t depth, size_t threads = 2) {
    pool_ = std::make_unique<WorkerPool>(threads);
    return std::make_shared<Session>("robot", *pool_, sink_, depth, [this](LogLevel level, const std::string& line) {
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
  // Installs a plugin and waits until the session reports it running.
  void install(Session& session, LocalizerPtr localizer, const std::string& plugin, uint64_t request_id) {
    const uint64_t generation = session.begin_request(request_id);
    session.install(generation, request_id, std::move(localizer), plugin, "ok");
    ASSERT_TRUE(sink_.wait_status("robot", [&](const SessionStatusReport& s) {
      return s.request_id == request_id && s.plugin == plugin && s.state == SessionState::kRunning;
    }));
  }
  bool wait_used(Session& session, uint64_t used) {
    for (int i = 0; i < 1000; ++i) {
      const auto c = session.status().counters;
      if (c.used + c.rejected >= used) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  }
  void TearDown() override {
    if (pool_) pool_->shutdown();
  }
  RecordingSink sink_;
  std::unique_ptr<WorkerPool> pool_;
  std::mutex log_mutex_;
  std::vector<std::pair<LogLevel, std::string>> log_;
};

TEST_F(SessionTest, MeasurementsRunInStampOrderAcrossKinds) {
  auto session = make(16);
  auto record = std::make_shared<Record>();
  // Queued before the plugin runs: arrival order 300, 100, 200 (three kinds).
  session->push(odometry(300));
  session->push(scan(100));
  Imu imu;
  imu.header.stamp_ns = 200;
  session->push(imu);
  install(*session, recording(record), "recording", 1);
  ASSERT_TRUE(wait_used(*session, 3));
  std::lock_guard<std::mutex> lock(record->mutex);
  EXPECT_EQ(record->stamps, (std::vector<int64_t>{100, 200, 300}));
}

TEST_F(SessionTest, FullQueueDropsTheOldestAndCountsIt) {
  auto session = make(3);
  auto record = std::make_shared<Record>();
  for (int64_t stamp = 1; stamp <= 5; ++stamp) session->push(odometry(stamp));
  EXPECT_EQ(session->status().counters.dropped, 2u);
  install(*session, recording(record), "recording", 1);
  ASSERT_TRUE(wait_used(*session, 3));
  const auto c = session->status().counters;
  EXPECT_EQ(c.received, 5u);
  EXPECT_EQ(c.used, 3u);
  EXPECT_EQ(c.dropped, 2u);
  EXPECT_EQ(c.updates, 3u);
  std::lock_guard<std::mutex> lock(record->mutex);
  EXPECT_EQ(record->stamps, (std::vector<int64_t>{3, 4, 5}));
}

TEST_F(SessionTest, FullQueueDropsTheOldestSensorFrameBeforeAnyOdometry) {
  auto session = make(3);
  auto record = std::make_shared<Record>();
  session->push(odometry(1));
  session->push(scan(2));
  session->push(odometry(3));
  session->push(scan(4));  // full: scan 2 goes, odometry 1 stays
  session->push(odometry(5));  // full: scan 4 goes
  session->push(odometry(6));  // only odometry left: the oldest, 1, goes
  EXPECT_EQ(session->status().counters.dropped, 3u);
  install(*session, recording(record), "recording", 1);
  ASSERT_TRUE(wait_used(*session, 3));
  std::lock_guard<std::mutex> lock(record->mutex);
  EXPECT_EQ(record->stamps, (std::vector<int64_t>{3, 5, 6}));
}

TEST_F(SessionTest, StampGoingBackwardsOnAKindIsRejectedAndNamed) {
  auto session = make(16);
  auto record = std::make_shared<Record>();
  install(*session, recording(record), "recording", 1);
  session->push(scan(1300));
  session->push(scan(1200));
  session->push(odometry(1200));  // another kind: its own order
  ASSERT_TRUE(wait_used(*session, 3));
  const auto status = session->status();
  EXPECT_EQ(status.counters.received, 3u);
  EXPECT_EQ(status.counters.rejected, 1u);
  EXPECT_EQ(status.counters.used, 2u);
  EXPECT_EQ(status.last_error, "stamp going backwards on locd/scan: 1200 < 1300 ns");
}

TEST_F(SessionTest, PluginInputErrorIsRejectedAndTheSessionGoesOn) {
  auto session = make(16);
  auto record = std::make_shared<Record>();
  install(*session, recording(record), "recording", 1);
  session->push(scan(10, -1.0f));
  session->push(odometry(20));
  ASSERT_TRUE(wait_used(*session, 2));
  const auto status = session->status();
  EXPECT_EQ(status.counters.rejected, 1u);
  EXPECT_EQ(status.counters.used, 1u);
  EXPECT_NE(status.last_error.find("locd/scan: negative range"), std::string::npos) << status.last_error;
  ASSERT_TRUE(sink_.wait_for([](const auto&, const auto& outputs) {
    return !outputs.empty() && outputs.back().result.estimate && outputs.back().result.estimate->header.stamp_ns == 20;
  }));
}

TEST_F(SessionTest, NeverTwoUpdatesAtOnce) {
  auto session = make(10000, 4);
  auto record = std::make_shared<Record>();
  install(*session, recording(record, std::chrono::microseconds(200)), "recording", 1);
  // Two producers (like two listener threads) push interleaved stamps of two kinds.
  std::thread odometry_thread([&] { for (int64_t i = 0; i < 200; ++i) session->push(odometry(2 * i)); });
  std::thread scan_thread([&] { for (int64_t i = 0; i < 200; ++i) session->push(scan(2 * i + 1)); });
  odometry_thread.join();
  scan_thread.join();
  ASSERT_TRUE(wait_used(*session, 400));
  EXPECT_EQ(record->max_inside.load(), 1);
  EXPECT_EQ(session->status().counters.used, 400u);
}

TEST_F(SessionTest, SwitchHandsTheLastPublishedPoseToTheNewPlugin) {
  auto session = make(16);
  auto old_record = std::make_shared<Record>();
  auto new_record = std::make_shared<Record>();
  install(*session, recording(old_record), "old_plugin", 1);
  session->push(odometry(4000));  // old plugin publishes x = 4.0
  ASSERT_TRUE(wait_used(*session, 1));
  install(*session, recording(new_record), "new_plugin", 2);
  EXPECT_EQ(old_record->destroyed.load(), 1);
  {
    std::lock_guard<std::mutex> lock(new_record->mutex);
    ASSERT_EQ(new_record->poses_set.size(), 1u);
    EXPECT_DOUBLE_EQ(new_record->poses_set[0].pose.translation().x(), 4.0);
    EXPECT_EQ(new_record->poses_set[0].header.stamp_ns, 4000);
  }
  session->push(odometry(5000));
  ASSERT_TRUE(wait_used(*session, 2));
  std::lock_guard<std::mutex> lock(new_record->mutex);
  EXPECT_EQ(new_record->stamps, (std::vector<int64_t>{5000}));
  EXPECT_EQ(session->status().plugin, "new_plugin");
}

TEST_F(SessionTest, FailedSwitchKeepsTheOldPluginAndReportsTheError) {
  auto session = make(16);
  auto record = std::make_shared<Record>();
  install(*session, recording(record), "old_plugin", 1);
  const uint64_t generation = session->begin_request(2);
  EXPECT_TRUE(session->fail_request(generation, 2, "parameter 'x.noise' = -1 is out of range"));
  const auto status = session->status();
  EXPECT_EQ(status.state, SessionState::kRunning);
  EXPECT_EQ(status.plugin, "old_plugin");
  EXPECT_EQ(status.request_id, 2u);
  EXPECT_FALSE(status.request_ok);
  EXPECT_EQ(status.message, "parameter 'x.noise' = -1 is out of range");
  session->push(odometry(10));
  ASSERT_TRUE(wait_used(*session, 1));
  EXPECT_EQ(record->destroyed.load(), 0);
  std::lock_guard<std::mutex> lock(record->mutex);
  EXPECT_EQ(record->stamps, (std::vector<int64_t>{10}));
}

TEST_F(SessionTest, SupersededRequestIsNotInstalled) {
  auto session = make(16);
  auto first = std::make_shared<Record>();
  auto second = std::make_shared<Record>();
  const uint64_t g1 = session->begin_request(1);
  const uint64_t g2 = session->begin_request(2);
  session->install(g2, 2, recording(second), "second", "ok");
  session->install(g1, 1, recording(first), "first", "ok");
  session->push(odometry(1));
  ASSERT_TRUE(wait_used(*session, 1));
  EXPECT_EQ(session->status().plugin, "second");
  EXPECT_EQ(first->destroyed.load(), 1);
}

TEST_F(SessionTest, StopReleasesThePluginAndRefusesFurtherMessages) {
  auto session = make(16);
  auto record = std::make_shared<Record>();
  install(*session, recording(record), "recording", 1);
  session->stop(2, "stopped by request 2");
  ASSERT_TRUE(sink_.wait_status("robot", [](const auto& s) { return s.state == SessionState::kStopped; }));
  EXPECT_EQ(record->destroyed.load(), 1);
  EXPECT_FALSE(session->push(odometry(1)));
}

TEST_F(SessionTest, InitialPoseReachesThePluginOnItsStrand) {
  auto session = make(16);
  auto record = std::make_shared<Record>();
  install(*session, recording(record), "recording", 1);
  PoseEstimate pose;
  pose.pose.translation() = Eigen::Vector3d(7.0, -1.0, 0.0);
  session->set_pose(pose);
  session->push(odometry(1));
  ASSERT_TRUE(wait_used(*session, 1));
  std::lock_guard<std::mutex> lock(record->mutex);
  ASSERT_EQ(record->poses_set.size(), 1u);
  EXPECT_DOUBLE_EQ(record->poses_set[0].pose.translation().x(), 7.0);
}

}  // namespace

namespace {

TEST_F(SessionTest, ANewRequestAcceptsARestartedRobotsClock) {
  auto session = make(16);
  auto record = std::make_shared<Record>();
  install(*session, recording(record), "recording", 1);
  session->push(odometry(5000));
  ASSERT_TRUE(wait_used(*session, 1));
  install(*session, recording(std::make_shared<Record>()), "recording", 2);
  session->push(odometry(10));  // the robot restarted: its clock begins again
  ASSERT_TRUE(wait_used(*session, 2));
  EXPECT_EQ(session->status().counters.rejected, 0u);
  EXPECT_EQ(session->status().counters.used, 2u);
}

}  // namespace

namespace {

TEST_F(SessionTest, ARejectionFloodIsCountedInFullAndLoggedWithinItsBudget) {
  auto session = make(16);
  auto record = std::make_shared<Record>();
  install(*session, recording(record), "recording", 1);
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

}  // namespace
