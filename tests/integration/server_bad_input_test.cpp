// Bad input against a real locd over real DDS (loopback): each TEST starts build/bin/locd as a
// child process with a temp config on its own domain id (50-69) and talks to it with the
// locd::dds Writer/Reader directly. Every bad input gets a clear error on the robot's status,
// is counted, and loses nothing else.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>

#include <cmath>
#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "child_process.hpp"
#include "locd/client/wire.hpp"
#include "locd/dds/convert.hpp"
#include "locd/dds/topics.hpp"
#include "test_env.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::dds::QosProfile;

constexpr auto kTimeout = 20s;
constexpr size_t kMaxScanBeams = 400;

using Status = locd::SessionStatus;

std::string describe(const Status& s) {
  return "robot " + s.robot_id + " state " + s.state + " plugin '" + s.plugin + "' request " +
         std::to_string(s.request_id) + (s.request_ok ? " ok" : " failed") + " message '" + s.message +
         "' last_error '" + s.last_error + "' received " + std::to_string(s.received) + " used " +
         std::to_string(s.used) + " dropped " + std::to_string(s.dropped) + " rejected " +
         std::to_string(s.rejected) + " updates " + std::to_string(s.updates) + " throttled " +
         std::to_string(s.throttled);
}

bool feature_ekf_built() { return fs::exists(fs::path(locd::test::plugin_dir()) / "liblocd_feature_ekf.so"); }

// A locd child process on its own domain, and a robot-side participant talking to it.
class LocdOverDds {
 public:
  explicit LocdOverDds(int domain, const std::string& extra_config = "") : domain_(domain) {
    dir_ = fs::temp_directory_path() / ("locd_bad_input_" + std::to_string(::getpid()) + "_" + std::to_string(domain));
    fs::create_directories(dir_);
    std::ofstream(dir_ / "locd.yaml") << "server_id: bad-input-test-" << domain << "\n"
                                      << "domain_id: " << domain << "\n"
                                      << "plugin_directories: [" << locd::test::plugin_dir() << ", "
                                      << LOCD_BROKEN_PLUGIN_DIR << "]\n"
                                      << "map_directories: [" << locd::test::source_dir() << "/config/maps]\n"
                                      << "status_period_s: 0.2\n"
                                      << "queue_depth: 1000\n"
                                      << "limits: {max_scan_beams: " << kMaxScanBeams << "}\n"
                                      << extra_config;
    locd_ = std::make_unique<locd::test::ChildProcess>(
        locd::test::binary_dir() + "/bin/locd", std::vector<std::string>{"--config", (dir_ / "locd.yaml").string()},
        (dir_ / "locd.log").string());

    participant_ = std::make_unique<locd::dds::Participant>(domain);
    // The test watches every robot, as an operator would.
    const locd::dds::Partitions every_robot{locd::topics::kAllRobotsPartition};
    statuses_ = locd::dds::Reader<locd_msg_SessionStatus>(
        *participant_, locd::topics::kSessionStatus, QosProfile::kState, [this](const locd_msg_SessionStatus& m) {
          const Status s = locd::status_from_wire(m);
          std::lock_guard<std::mutex> lock(mutex_);
          history_.push_back(s);
          changed_.notify_all();
        },
        8, every_robot);
    poses_ = locd::dds::Reader<locd_msg_PoseEstimate>(
        *participant_, locd::topics::kPose, QosProfile::kPose, [this](const locd_msg_PoseEstimate& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          pose_stamps_[locd::dds::to_string(m.robot_id)].push_back(m.header.stamp_ns);
          changed_.notify_all();
        },
        8, every_robot);
  }

  ~LocdOverDds() {
    statuses_ = {};
    poses_ = {};
    robots_.clear();
    if (locd_->running()) {
      locd_->signal(SIGTERM);
      locd_->wait(10s);
    }
    std::error_code ec;
    if (!::testing::Test::HasFailure()) fs::remove_all(dir_, ec);
  }

  // Sends a request and waits for its outcome on the status topic.
  // `from`: the robot whose partition the request is written in (default: `robot`'s own).
  Status request(const std::string& robot, uint64_t id, const std::string& plugin, const std::string& yaml,
                 locd_msg_SessionAction action = locd_msg_SESSION_START, const std::string& from = "") {
    send_request(robot, id, plugin, yaml, action, from);
    return wait_status(robot, [id](const Status& s) { return s.request_id == id && s.state != "starting"; });
  }
  void send_request(const std::string& robot, uint64_t id, const std::string& plugin, const std::string& yaml,
                    locd_msg_SessionAction action, const std::string& from) {
    auto sample = std::make_unique<locd_msg_SessionRequest>();
    std::memset(sample.get(), 0, sizeof(locd_msg_SessionRequest));
    locd::dds::copy_string(sample->robot_id, robot);
    sample->request_id = id;
    sample->action = action;
    locd::dds::copy_string(sample->plugin, plugin);
    locd::dds::borrow_text(sample->config_yaml, yaml, locd::topics::kMaxConfigYamlBytes);
    endpoints(from.empty() ? robot : from).requests.write(*sample);
  }

  // Waits for a status of `robot` matching `pred`; fails the test with the last one seen.
  Status wait_status(const std::string& robot, const std::function<bool(const Status&)>& pred) {
    std::unique_lock<std::mutex> lock(mutex_);
    std::optional<Status> found;
    const bool ok = changed_.wait_for(lock, kTimeout, [&] {
      for (auto it = history_.rbegin(); it != history_.rend(); ++it) {
        if (it->robot_id == robot && pred(*it)) {
          found = *it;
          return true;
        }
      }
      return false;
    });
    if (!ok) {
      std::string last = "(none)";
      for (auto it = history_.rbegin(); it != history_.rend(); ++it) {
        if (it->robot_id == robot) {
          last = describe(*it);
          break;
        }
      }
      ADD_FAILURE() << "no matching status for " << robot << "; last: " << last << "\nlocd log:\n" << locd_->output();
      return {};
    }
    return *found;
  }

  size_t poses(const std::string& robot) {
    std::lock_guard<std::mutex> lock(mutex_);
    return pose_stamps_[robot].size();
  }
  std::vector<int64_t> pose_stamps(const std::string& robot) {
    std::lock_guard<std::mutex> lock(mutex_);
    return pose_stamps_[robot];
  }
  bool wait_pose_stamp(const std::string& robot, int64_t stamp) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, kTimeout, [&] {
      const auto& stamps = pose_stamps_[robot];
      return std::find(stamps.begin(), stamps.end(), stamp) != stamps.end();
    });
  }
  bool wait_poses(const std::string& robot, size_t count) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, kTimeout, [&] { return pose_stamps_[robot].size() >= count; });
  }

  void send_scan(const std::string& robot, int64_t stamp, std::vector<float> ranges, const std::string& from = "") {
    locd::LaserScan scan;
    scan.header = {stamp, "laser"};
    scan.angle_min = static_cast<float>(-M_PI / 2);
    scan.angle_increment = ranges.size() > 1 ? static_cast<float>(M_PI / (ranges.size() - 1)) : 0.01f;
    scan.range_min = 0.05f;
    scan.range_max = 30.0f;
    scan.ranges = std::move(ranges);
    locd::dds::write(endpoints(from.empty() ? robot : from).scans, robot, scan);
  }
  void send_odometry(const std::string& robot, int64_t stamp, double x, const std::string& from = "") {
    locd::Odometry odometry;
    odometry.header = {stamp, "odom"};
    odometry.pose.translation() = Eigen::Vector3d(x, 0.0, 0.0);
    odometry.linear_velocity = Eigen::Vector3d(0.5, 0.0, 0.0);
    locd::dds::write(endpoints(from.empty() ? robot : from).odometry, robot, odometry);
  }

  // The writers of a robot's side, in the partition of `partition_robot` (default: the robot's
  // own, as a robot publishes), made on first use once the server's readers matched them.
  struct RobotEndpoints {
    RobotEndpoints(const locd::dds::Participant& p, const std::string& partition_robot)
        : requests(p, locd::topics::kSessionRequest, QosProfile::kState, 8,
                   {locd::topics::robot_partition(partition_robot)}),
          scans(p, locd::topics::kScan, QosProfile::kSensor, 8, {locd::topics::robot_partition(partition_robot)}),
          odometry(p, locd::topics::kOdometry, QosProfile::kSensor, 64,
                   {locd::topics::robot_partition(partition_robot)}) {}
    locd::dds::Writer<locd_msg_SessionRequest> requests;
    locd::dds::Writer<locd_msg_LaserScan> scans;
    locd::dds::Writer<locd_msg_Odometry> odometry;
  };
  RobotEndpoints& endpoints(const std::string& partition_robot) {
    auto& slot = robots_[partition_robot];
    if (!slot) {
      slot = std::make_unique<RobotEndpoints>(*participant_, partition_robot);
      const auto deadline = std::chrono::steady_clock::now() + kTimeout;
      // (The server's writers of this robot's outputs appear with its first status: readers match
      // them then, and transient-local delivers what was written.)
      while (slot->requests.matched() == 0 || slot->scans.matched() == 0 || slot->odometry.matched() == 0) {
        if (std::chrono::steady_clock::now() > deadline || !locd_->running()) {
          throw std::runtime_error("locd did not match robot '" + partition_robot + "' on domain " +
                                   std::to_string(domain_) + ":\n" + locd_->output());
        }
        std::this_thread::sleep_for(10ms);
      }
    }
    return *slot;
  }

  // The robot's side in `partition_robot` leaves: its writers are deleted.
  void forget(const std::string& partition_robot) { robots_.erase(partition_robot); }

  locd::test::ChildProcess& locd() { return *locd_; }

 private:
  int domain_;
  fs::path dir_;
  std::unique_ptr<locd::test::ChildProcess> locd_;
  std::unique_ptr<locd::dds::Participant> participant_;
  std::map<std::string, std::unique_ptr<RobotEndpoints>> robots_;
  locd::dds::Reader<locd_msg_SessionStatus> statuses_;
  locd::dds::Reader<locd_msg_PoseEstimate> poses_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Status> history_;
  std::map<std::string, std::vector<int64_t>> pose_stamps_;
};

const std::string kFixtureConfig = "plugin: fixture_odometry\nparams:\n  position_stddev: 0.1\n";
const std::string kFeatureEkfConfig = "plugin: feature_ekf\nparams:\n  map: corridor.yaml\n";

#define EXPECT_CONTAINS(text, part) EXPECT_NE((text).find(part), std::string::npos) << "'" << (part) << "' not in: " << (text)

TEST(ServerBadInput, MalformedYamlNamesLineAndColumn) {
  LocdOverDds locd(50);
  const auto s = locd.request("robot_yaml", 1, "", "plugin: fixture_odometry\nparams:\n  position_stddev: [0.1\n");
  EXPECT_FALSE(s.request_ok);
  EXPECT_EQ(s.state, "error");
  EXPECT_CONTAINS(s.message, "malformed YAML at line 4, column 1");
  EXPECT_CONTAINS(s.message, "session request 1 for robot 'robot_yaml'");
}

TEST(ServerBadInput, UnknownPluginListsTheKnownOnes) {
  LocdOverDds locd(51);
  const auto s = locd.request("robot_unknown", 1, "", "plugin: particle_magic\n");
  EXPECT_FALSE(s.request_ok);
  EXPECT_CONTAINS(s.message, "unknown plugin 'particle_magic'; known plugins: ");
  EXPECT_CONTAINS(s.message, "fixture_odometry");
  if (feature_ekf_built()) {
    EXPECT_CONTAINS(s.message, "feature_ekf");
  }
}

TEST(ServerBadInput, PathAsPluginNameIsRefused) {
  LocdOverDds locd(52);
  auto s = locd.request("robot_path", 1, "../../tmp/liblocd_evil.so", kFixtureConfig);
  EXPECT_FALSE(s.request_ok);
  EXPECT_CONTAINS(s.message, "plugin must be a name, not a path");
  s = locd.request("robot_path", 2, "", "plugin: /tmp/liblocd_evil.so\n");
  EXPECT_FALSE(s.request_ok);
  EXPECT_CONTAINS(s.message, "plugin '/tmp/liblocd_evil.so': plugin must be a name, not a path");
}

TEST(ServerBadInput, MapOutsideTheMapDirectoriesIsRefusedNamingTheFile) {
  if (!feature_ekf_built()) GTEST_SKIP() << "needs build/plugins/liblocd_feature_ekf.so";
  LocdOverDds locd(53);
  auto s = locd.request("robot_map", 1, "", "plugin: feature_ekf\nparams:\n  map: ../../etc/passwd\n");
  EXPECT_FALSE(s.request_ok);
  EXPECT_CONTAINS(s.message, "map file '../../etc/passwd' contains '..'");
  s = locd.request("robot_map", 2, "", "plugin: feature_ekf\nparams:\n  map: /etc/passwd\n");
  EXPECT_FALSE(s.request_ok);
  EXPECT_CONTAINS(s.message, "map file '/etc/passwd' is an absolute path");
  s = locd.request("robot_map", 3, "", "plugin: feature_ekf\nparams:\n  map: no_such_map.yaml\n");
  EXPECT_FALSE(s.request_ok);
  EXPECT_CONTAINS(s.message, "map file 'no_such_map.yaml' not found in the map directories");
}

TEST(ServerBadInput, ParameterOutOfRangeNamesKeyAndAllowedRange) {
  if (!feature_ekf_built()) GTEST_SKIP() << "needs build/plugins/liblocd_feature_ekf.so";
  LocdOverDds locd(54);
  const auto s = locd.request("robot_param", 1, "",
                              "plugin: feature_ekf\nparams:\n  map: corridor.yaml\n  motion:\n"
                              "    speed_stddev_per_speed: -0.5\n");
  EXPECT_FALSE(s.request_ok);
  EXPECT_CONTAINS(s.message, "parameter 'feature_ekf.motion.speed_stddev_per_speed' (line 5, column 29) = -0.5 "
                             "is out of range; allowed: [0, inf]");
}

TEST(ServerBadInput, MessageForARobotWithoutSessionIsAnswered) {
  LocdOverDds locd(55);
  locd.send_scan("robot_ghost", 1000, std::vector<float>(100, 2.0f));
  const auto s = locd.wait_status("robot_ghost", [](const Status& st) { return st.state == "no_session"; });
  EXPECT_CONTAINS(s.last_error, "no session for robot 'robot_ghost': message on locd/scan ignored");
  EXPECT_CONTAINS(s.last_error, "send a session request on locd/session_request");
  EXPECT_GE(s.received, 1u);
  EXPECT_EQ(s.received, s.rejected);
}

TEST(ServerBadInput, OversizedScanIsRejectedBeforeConversion) {
  LocdOverDds locd(56);
  ASSERT_TRUE(locd.request("robot_big", 1, "", kFixtureConfig).request_ok);
  locd.send_scan("robot_big", 1000, std::vector<float>(kMaxScanBeams + 1, 2.0f));
  const auto s = locd.wait_status("robot_big", [](const Status& st) { return st.rejected == 1; });
  EXPECT_CONTAINS(s.last_error, "locd/scan");
  EXPECT_CONTAINS(s.last_error, "401 beams exceed the limit max_scan_beams = 400");
  EXPECT_EQ(s.received, 1u);
  EXPECT_EQ(s.used, 0u);
}

TEST(ServerBadInput, EmptyAndAllNanScansAreRejected) {
  LocdOverDds locd(57);
  ASSERT_TRUE(locd.request("robot_nan", 1, "", kFixtureConfig).request_ok);
  locd.send_scan("robot_nan", 1000, {});
  auto s = locd.wait_status("robot_nan", [](const Status& st) { return st.rejected == 1; });
  EXPECT_CONTAINS(s.last_error, "locd/scan: scan: empty (0 beams)");
  locd.send_scan("robot_nan", 2000, std::vector<float>(50, std::numeric_limits<float>::quiet_NaN()));
  s = locd.wait_status("robot_nan", [](const Status& st) { return st.rejected == 2; });
  EXPECT_CONTAINS(s.last_error, "no beam is a return");
  std::vector<float> infinite(50, std::numeric_limits<float>::infinity());
  locd.send_scan("robot_nan", 3000, infinite);
  s = locd.wait_status("robot_nan", [](const Status& st) { return st.rejected == 3; });
  EXPECT_EQ(s.received, 3u);
  EXPECT_EQ(s.used, 0u);
}

TEST(ServerBadInput, StampsGoingBackwardsAreRejectedAndNamed) {
  LocdOverDds locd(58);
  ASSERT_TRUE(locd.request("robot_time", 1, "", kFixtureConfig).request_ok);
  // A first message the server is known to have taken: a writer that has just matched the
  // server's reader may still be unknown to it, and a sample sent then never arrives.
  locd.send_odometry("robot_time", 1000, 0.0);
  locd.wait_status("robot_time", [](const Status& st) { return st.used == 1; });
  locd.send_odometry("robot_time", 1300, 0.0);
  locd.send_odometry("robot_time", 1200, 0.1);
  locd.send_odometry("robot_time", 1400, 0.2);
  const auto s = locd.wait_status("robot_time", [](const Status& st) { return st.used + st.rejected == 4; });
  EXPECT_EQ(s.rejected, 1u);
  EXPECT_EQ(s.used, 3u);
  EXPECT_EQ(s.last_error, "stamp going backwards on locd/odometry: 1200 < 1300 ns");
  // The pose of 1000 may go out before this test's reader has matched the session's new pose
  // writer (seen once on a loaded machine); those after it are checked.
  ASSERT_TRUE(locd.wait_pose_stamp("robot_time", 1400));
  const std::vector<int64_t> stamps = locd.pose_stamps("robot_time");
  EXPECT_EQ(std::count(stamps.begin(), stamps.end(), 1300), 1);
  EXPECT_EQ(std::count(stamps.begin(), stamps.end(), 1200), 0);
  EXPECT_TRUE(std::is_sorted(stamps.begin(), stamps.end()));
}

// Every bad input above against one server, then a good session on another robot: it runs and
// its counters are exact; the server stays up.
TEST(ServerBadInput, AfterAllBadInputAGoodSessionStillRuns) {
  LocdOverDds locd(59);
  locd.request("bad", 1, "", "plugin: [unclosed\n");
  locd.request("bad", 2, "", "plugin: particle_magic\n");
  locd.request("bad", 3, "/tmp/evil.so", kFixtureConfig);
  locd.request("bad", 4, "", "plugin: broken_configure_throws\n");
  locd.send_scan("nobody", 10, std::vector<float>(10, 1.0f));
  ASSERT_TRUE(locd.request("bad", 5, "", kFixtureConfig).request_ok);
  locd.send_scan("bad", 100, std::vector<float>(kMaxScanBeams * 2, 1.0f));
  locd.send_scan("bad", 200, {});
  locd.send_scan("bad", 300, std::vector<float>(20, std::numeric_limits<float>::quiet_NaN()));
  locd.send_odometry("bad", 500, 0.0);
  locd.send_odometry("bad", 400, 0.0);
  const auto bad = locd.wait_status("bad", [](const Status& s) { return s.used + s.rejected == 5; });
  EXPECT_EQ(bad.rejected, 4u) << describe(bad);

  const bool real_plugin = feature_ekf_built();
  const std::string robot = "good";
  ASSERT_TRUE(locd.request(robot, 1, "", real_plugin ? kFeatureEkfConfig : kFixtureConfig).request_ok);
  constexpr int kSteps = 25;
  constexpr int64_t kPeriod = 40'000'000;  // 25 Hz
  for (int k = 1; k <= kSteps; ++k) {
    locd.send_odometry(robot, k * kPeriod, 0.01 * k);
    std::vector<float> ranges(181);
    for (size_t i = 0; i < ranges.size(); ++i) ranges[i] = 1.0f + 0.001f * static_cast<float>(i);
    locd.send_scan(robot, k * kPeriod + 1'000'000, ranges);
  }
  const auto good = locd.wait_status(robot, [](const Status& s) { return s.used + s.rejected + s.dropped == 2 * kSteps; });
  EXPECT_EQ(good.received, 2u * kSteps) << describe(good);
  EXPECT_EQ(good.used, 2u * kSteps) << describe(good);
  EXPECT_EQ(good.rejected, 0u) << describe(good);
  EXPECT_EQ(good.dropped, 0u) << describe(good);
  // feature_ekf publishes a pose per scan; the fixture one per odometry message.
  EXPECT_EQ(good.updates, static_cast<uint64_t>(kSteps)) << describe(good);
  EXPECT_EQ(good.plugin, real_plugin ? "feature_ekf" : "fixture_odometry");
  EXPECT_TRUE(locd.wait_poses(robot, kSteps));
  EXPECT_TRUE(locd.locd().running());
  locd.locd().signal(SIGTERM);
  EXPECT_EQ(locd.locd().wait(10s), 0);
  EXPECT_CONTAINS(locd.locd().output(), "stopped");
}

}  // namespace

TEST(ServerBadInput, RequestsBeyondMaxSessionsAreRefusedAndTheOthersRun) {
  LocdOverDds locd(62, "max_sessions: 2\n");
  EXPECT_TRUE(locd.request("robot_a", 1, "", kFixtureConfig).request_ok);
  EXPECT_TRUE(locd.request("robot_b", 1, "", kFixtureConfig).request_ok);
  const auto refused = locd.request("robot_c", 1, "", kFixtureConfig);
  EXPECT_FALSE(refused.request_ok);
  EXPECT_CONTAINS(refused.message, "max_sessions = 2");
  // A running robot may still switch its plugin, and a freed slot serves the next robot.
  EXPECT_TRUE(locd.request("robot_a", 2, "", kFixtureConfig).request_ok);
  EXPECT_TRUE(locd.request("robot_b", 2, "", "", locd_msg_SESSION_STOP).request_id == 2);
  EXPECT_TRUE(locd.request("robot_c", 2, "", kFixtureConfig).request_ok);
}

// Addressing: a sample travels in its robot's partition robot.<robot_id>. Written by robot A's
// side for robot B, a start, a stop and sensor data are refused and reported on A's status; B's
// session runs on untouched. (With DDS Security, A's identity cannot even publish in B's
// partition; this is what stays true in plain mode.)
TEST(ServerBadInput, ARobotCanNeitherStopNorFeedAnotherRobot) {
  LocdOverDds locd(190);
  ASSERT_TRUE(locd.request("robot_b", 1, "", kFixtureConfig).request_ok);
  ASSERT_TRUE(locd.request("robot_a", 1, "", kFixtureConfig).request_ok);
  locd.send_request("robot_b", 2, "", "", locd_msg_SESSION_STOP, "robot_a");
  locd.send_odometry("robot_b", 1000, 25.0, "robot_a");
  const auto a = locd.wait_status("robot_a", [](const Status& s) { return s.rejected >= 2; });
  EXPECT_CONTAINS(a.last_error, "a sample for robot 'robot_b' was published in partition [robot.robot_a]");
  locd.send_odometry("robot_b", 2000, 1.0);
  ASSERT_TRUE(locd.wait_poses("robot_b", 1));
  const auto b = locd.wait_status("robot_b", [](const Status& s) { return s.used == 1; });
  EXPECT_EQ(b.state, "running");
  EXPECT_EQ(b.received, 1u) << describe(b);
  EXPECT_EQ(locd.pose_stamps("robot_b"), (std::vector<int64_t>{2000}));
}

// Session pinning: robot B writing samples that name robot A in B's own partition is refused,
// and its writer must not keep A's session alive either once A has left (A's DDS instance keeps a
// live writer, B's, which the server does not count).
TEST(ServerBadInput, ARobotNamingAnotherInItsOwnPartitionDoesNotKeepThatRobotsSession) {
  LocdOverDds locd(205, "session_grace_s: 0.5\n");
  ASSERT_TRUE(locd.request("robot_a", 1, "", kFixtureConfig).request_ok);
  locd.send_odometry("robot_a", 1000, 0.0);
  ASSERT_TRUE(locd.wait_poses("robot_a", 1));
  // Robot B, a process of its own, writes odometry naming A in B's partition.
  locd::dds::Participant robot_b(205);
  locd::dds::Writer<locd_msg_Odometry> b(robot_b, locd::topics::kOdometry, QosProfile::kSensor, 8,
                                         {locd::topics::robot_partition("robot_b")});
  std::atomic<bool> done{false};
  std::thread squatter([&] {
    locd::Odometry odometry;
    odometry.header = {2000, "odom"};
    while (!done) {
      odometry.header.stamp_ns += 100'000'000;
      locd::dds::write(b, "robot_a", odometry);
      std::this_thread::sleep_for(100ms);
    }
  });
  std::this_thread::sleep_for(1s);  // B's samples reach the server while A is still there
  locd.forget("robot_a");           // A leaves
  const auto ended = locd.wait_status("robot_a", [](const Status& s) { return s.state == "stopped"; });
  done = true;
  squatter.join();
  EXPECT_CONTAINS(ended.message, "session ended: no live writer of robot 'robot_a'");
}

// Rate limits over DDS: robot "flooder" writes session requests with fresh ids as fast as it can
// from a participant of its own, in its own partition, until its status counts some as
// throttled. The server started its plugin no more often than its limit allows (default 1/s with
// a burst of 10), and robot "steady" kept its session, unrestarted, with poses for its odometry.
TEST(ServerBadInput, ARequestFloodIsCutToTheRobotsLimitAndAnotherRobotKeepsItsSession) {
  LocdOverDds locd(206);
  ASSERT_TRUE(locd.request("steady", 1, "", kFixtureConfig).request_ok);
  locd::dds::Participant flooder_side(206);
  locd::dds::Writer<locd_msg_SessionRequest> flood(flooder_side, locd::topics::kSessionRequest, QosProfile::kState, 8,
                                                   {locd::topics::robot_partition("flooder")});
  auto sample = std::make_unique<locd_msg_SessionRequest>();
  std::memset(sample.get(), 0, sizeof(locd_msg_SessionRequest));
  locd::dds::copy_string(sample->robot_id, "flooder");
  locd::dds::borrow_text(sample->config_yaml, kFixtureConfig, locd::topics::kMaxConfigYamlBytes);
  sample->action = locd_msg_SESSION_START;
  const auto start = std::chrono::steady_clock::now();
  std::atomic<bool> done{false};
  std::thread flooder([&] {
    while (!done) {
      ++sample->request_id;
      flood.write(*sample);
    }
  });
  int64_t stamp = 1000;
  for (int i = 0; i < 20; ++i) {  // steady's odometry at 20 Hz meanwhile
    locd.send_odometry("steady", stamp += 50'000'000, 0.01 * i);
    std::this_thread::sleep_for(50ms);
  }
  const auto throttled = locd.wait_status("flooder", [](const Status& s) { return s.throttled > 0; });
  done = true;
  flooder.join();
  EXPECT_CONTAINS(throttled.last_error, "of robot 'flooder' dropped: over the robot's limit of 1 a second (burst 10), "
                                        "request_limits.session_requests in the server config");
  // steady: never restarted, nothing throttled, and its odometry still answered.
  locd.send_odometry("steady", stamp += 50'000'000, 1.0);
  EXPECT_TRUE(locd.wait_pose_stamp("steady", stamp));
  const auto steady = locd.wait_status("steady", [](const Status& s) { return s.used >= 1; });
  EXPECT_EQ(steady.request_id, 1u) << describe(steady);
  EXPECT_EQ(steady.state, "running");
  EXPECT_EQ(steady.throttled, 0u);
  // The flooder's plugin was started at most burst + rate x elapsed times (each start is a line).
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::string log = locd.locd().output();
  size_t starts = 0;  // "[flooder] session request N" lines (not the ones saying it was dropped)
  std::istringstream lines(log);
  for (std::string line; std::getline(lines, line);) {
    starts += line.find("[flooder] session request ") != std::string::npos && line.find("dropped") == std::string::npos;
  }
  EXPECT_GE(starts, 1u);
  EXPECT_LE(static_cast<double>(starts), 10 + 1 + elapsed_s) << "in " << elapsed_s << " s:\n" << log;
  std::cout << "flood: " << sample->request_id << " requests written in " << elapsed_s << " s, " << starts
            << " plugin starts, " << throttled.throttled << " throttled (on the status)\n";
}

// One participant naming many robots (here 10, with a budget of 3 across them): three start, the
// others are answered naming the participant (its GUID, as discovery announced it) and the limit;
// a robot of another participant starts as before.
TEST(ServerBadInput, AParticipantNamingManyRobotsIsLimitedAcrossThemByItsGuid) {
  LocdOverDds locd(207, "request_limits: {session_requests_per_participant: {per_s: 0.001, burst: 3}}\n");
  locd::dds::Participant operator_side(207);
  locd::dds::Partitions partitions;
  for (int i = 0; i < 10; ++i) partitions.push_back(locd::topics::robot_partition("m_" + std::to_string(i)));
  locd::dds::Writer<locd_msg_SessionRequest> requests(operator_side, locd::topics::kSessionRequest, QosProfile::kState,
                                                      8, partitions);
  const auto deadline = std::chrono::steady_clock::now() + kTimeout;
  while (requests.matched() == 0 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(10ms);
  ASSERT_GT(requests.matched(), 0u) << locd.locd().output();
  auto sample = std::make_unique<locd_msg_SessionRequest>();
  std::memset(sample.get(), 0, sizeof(locd_msg_SessionRequest));
  locd::dds::borrow_text(sample->config_yaml, kFixtureConfig, locd::topics::kMaxConfigYamlBytes);
  sample->action = locd_msg_SESSION_START;
  sample->request_id = 1;
  for (int i = 0; i < 10; ++i) {
    locd::dds::copy_string(sample->robot_id, "m_" + std::to_string(i));
    requests.write(*sample);
  }
  int started = 0, refused = 0;
  for (int i = 0; i < 10; ++i) {
    const auto s = locd.wait_status("m_" + std::to_string(i), [](const Status& s) {
      return s.request_id == 1 && s.state != "starting";
    });
    if (s.request_ok) {
      ++started;
      continue;
    }
    ++refused;
    EXPECT_CONTAINS(s.message, "session request 1 of robot 'm_" + std::to_string(i) + "' dropped: its writer's participant ");
    EXPECT_CONTAINS(s.message, " is over its limit of 0.001 a second (burst 3) across the robots it names, "
                               "request_limits.session_requests_per_participant in the server config");
    const size_t at = s.message.find("participant ") + 12;
    const std::string guid = s.message.substr(at, s.message.find(' ', at) - at);
    EXPECT_EQ(guid.size(), 32u) << guid;
    EXPECT_EQ(guid.find_first_not_of("0123456789abcdef"), std::string::npos) << guid;
  }
  EXPECT_EQ(started, 3);
  EXPECT_EQ(refused, 7);
  EXPECT_TRUE(locd.request("own", 1, "", kFixtureConfig).request_ok);
}

// A robot id outside [A-Za-z0-9_.-]{1,64} is refused before anything is kept for it, and the log
// line naming it is escaped: a newline in it cannot forge a line.
TEST(ServerBadInput, RobotIdsOutsideTheAllowedCharactersAreRefusedAndEscapedInTheLog) {
  LocdOverDds locd(191);
  locd.send_odometry("evil\n2026-01-01T00:00:00.000Z info [server] forged", 1000, 0.0);
  ASSERT_TRUE(locd.request("robot_ok", 1, "", kFixtureConfig).request_ok);
  const auto deadline = std::chrono::steady_clock::now() + kTimeout;
  std::string log;
  while (std::chrono::steady_clock::now() < deadline) {
    log = locd.locd().output();
    if (log.find("refused a message on locd/odometry") != std::string::npos) break;
    std::this_thread::sleep_for(20ms);
  }
  EXPECT_CONTAINS(log, "refused a message on locd/odometry: robot_id 'evil\\n2026-01-01T00:00:00.000Z info [server] "
                       "forged' contains '\\n'; allowed: 1-64 characters of [A-Za-z0-9_.-]");
  EXPECT_EQ(log.find("\n2026-01-01T00:00:00.000Z info [server] forged"), std::string::npos) << log;
}
