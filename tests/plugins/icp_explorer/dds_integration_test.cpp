// icp_explorer inside a real locd over real DDS (loopback, domain 90): a robot starts an
// icp_explorer session with the toy two-room world's parameters, stops and scans three times
// with odometry in between, and gets a registered pose per scan near the truth, the registered
// map (transient-local) and an exploration goal; an all-NaN cloud is rejected with a clear error
// on its status, counted, and the session carries on; a map save request (no path in it) writes
// the map into the directory of the plugin's config and names the file on the status.
#include <gtest/gtest.h>

#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <thread>

#include "test_server.hpp"
#include "locd/dds/convert.hpp"
#include "locd/dds/topics.hpp"
#include "test_env.hpp"
#include "toy_world.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::dds::QosProfile;

constexpr int kDomain = 90;
constexpr auto kTimeout = 60s;
const char* kRobot = "scanner_bot";

struct Seen {
  std::mutex mutex;
  std::condition_variable changed;
  std::map<int64_t, Eigen::Isometry3d> poses;
  std::vector<locd::ExplorationGoal> goals;
  std::string goal_plugin;
  size_t map_points = 0;
  uint64_t rejected = 0, request_id = 0;
  bool request_ok = false;
  std::string last_error, message;
  bool running = false;
};

const std::string kPluginConfig = R"(plugin: icp_explorer
params:
  max_points: 50000
  rejection: {max_range: 15.0}
  exploration: {origin: [-0.5, -0.5], size: [11.0, 5.0], rays: 60, candidate_stride: 3, done_threshold: 2.0}
  map_output: {publish_every_scans: 1, publish_voxel_size: 0.3}
)";

TEST(IcpExplorerOverDds, RegistersScansPublishesMapAndGoalAndRejectsABadCloud) {
  locd::test::TestServer server("icp_explorer_dds", kDomain, {"", "output_directory: maps\n", 64});
  locd::test::ChildProcess& locd = server.process();
  const fs::path& dir = server.dir();
  Seen seen;
  locd::dds::Participant participant(kDomain);
  locd::dds::Writer<locd_msg_SessionRequest> requests(participant, locd::topics::kSessionRequest, QosProfile::kState);
  locd::dds::Writer<locd_msg_InitialPose> initial_pose(participant, locd::topics::kInitialPose, QosProfile::kState);
  locd::dds::Writer<locd_msg_Odometry> odometry(participant, locd::topics::kOdometry, QosProfile::kSensor, 16);
  locd::dds::Writer<locd_msg_PointCloud> clouds(participant, locd::topics::kCloud, QosProfile::kSensor, 4);
  locd::dds::Writer<locd_msg_MapSaveRequest> save_requests(participant, locd::topics::kMapSaveRequest,
                                                           QosProfile::kSensor);
  locd::dds::Reader<locd_msg_SessionStatus> statuses(
      participant, locd::topics::kSessionStatus, QosProfile::kState, [&](const locd_msg_SessionStatus& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.rejected = m.rejected;
        seen.request_id = m.request_id;
        seen.request_ok = m.request_ok;
        seen.last_error = locd::dds::to_string(m.last_error);
        seen.message = locd::dds::to_string(m.message);
        seen.running = m.state == locd_msg_STATE_RUNNING;
        seen.changed.notify_all();
      });
  locd::dds::Reader<locd_msg_PoseEstimate> poses(
      participant, locd::topics::kPose, QosProfile::kPose, [&](const locd_msg_PoseEstimate& m) {
        const locd::PoseEstimate p = locd::dds::from_wire(m);
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.poses[p.header.stamp_ns] = p.pose;
        seen.changed.notify_all();
      });
  locd::dds::Reader<locd_msg_ExplorationGoal> goals(
      participant, locd::topics::kExplorationGoal, QosProfile::kState, [&](const locd_msg_ExplorationGoal& m) {
        const locd::ExplorationGoal g = locd::dds::from_wire(m);
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.goals.push_back(g);
        seen.goal_plugin = locd::dds::to_string(m.plugin);
        seen.changed.notify_all();
      });
  locd::dds::Reader<locd_msg_PointCloudMap> maps(
      participant, locd::topics::kMapCloud, QosProfile::kState, [&](const locd_msg_PointCloudMap& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.map_points = m.xyz._length / 3;
        seen.changed.notify_all();
      });
  const auto deadline = std::chrono::steady_clock::now() + kTimeout;
  while (requests.matched() == 0 || clouds.matched() == 0 || statuses.matched() == 0 || goals.matched() == 0) {
    ASSERT_TRUE(std::chrono::steady_clock::now() < deadline && locd.running()) << "locd did not come up:\n" << locd.output();
    std::this_thread::sleep_for(10ms);
  }

  auto request = std::make_unique<locd_msg_SessionRequest>();
  std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
  locd::dds::copy_string(request->robot_id, kRobot);
  request->request_id = 1;
  request->action = locd_msg_SESSION_START;
  locd::dds::copy_string(request->plugin, "icp_explorer");
  locd::dds::copy_string(request->config_yaml, kPluginConfig);
  requests.write(*request);
  {
    std::unique_lock<std::mutex> lock(seen.mutex);
    ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] { return seen.running; }))
        << "session not running: " << seen.message << "\n" << locd.output();
  }
  const std::vector<locd::Pose2> stops = {{3.0, 1.2, 0.0}, {3.8, 1.5, 0.2}, {4.6, 2.0, 0.5}};
  locd::PoseEstimate start;
  start.header.stamp_ns = 500'000'000;
  start.pose = stops[0].to_isometry();
  locd::dds::write(initial_pose, kRobot, start);

  const locd::sim::IndoorWorld world = locd::test::two_rooms();
  const locd::sim::Scanner3D scanner(locd::test::coarse_scanner());
  std::mt19937_64 rng(11);
  // Odometry off by (0.2 m, -4 deg) per leg.
  locd::Pose2 odom = stops[0];
  std::map<int64_t, locd::Pose2> truth;
  for (size_t k = 0; k < stops.size(); ++k) {
    const int64_t stamp = static_cast<int64_t>(k + 1) * 1'000'000'000;
    if (k > 0) odom = odom * (stops[k - 1].inverse() * stops[k]) * locd::Pose2(0.2, 0.0, -4.0 * M_PI / 180);
    locd::Odometry o;
    o.header.stamp_ns = stamp - 1000;
    o.header.frame_id = "odom";
    o.pose = odom.to_isometry();
    locd::dds::write(odometry, kRobot, o);
    auto scan = scanner.scan(world, stops[k].to_isometry(), 0.0, stamp, rng).cloud;
    locd::dds::write(clouds, kRobot, scan);
    truth[stamp] = stops[k];
    std::unique_lock<std::mutex> lock(seen.mutex);
    ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] { return seen.poses.count(stamp) > 0; }))
        << "no pose for scan " << k << ": " << seen.last_error << "\n" << locd.output();
    if (k == 0) {
      // A cloud of NaN points between the scans: rejected, named, counted.
      lock.unlock();
      locd::PointCloud bad;
      bad.header.stamp_ns = stamp + 1000;
      bad.points.assign(100, Eigen::Vector3f(NAN, NAN, NAN));
      locd::dds::write(clouds, kRobot, bad);
      lock.lock();
      ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] { return seen.rejected >= 1; })) << locd.output();
      EXPECT_NE(seen.last_error.find("cloud"), std::string::npos) << seen.last_error;
    }
  }

  std::unique_lock<std::mutex> lock(seen.mutex);
  ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] { return seen.goals.size() >= 3 && seen.map_points > 0; }))
      << "goals " << seen.goals.size() << ", map points " << seen.map_points << "\n" << locd.output();
  for (const auto& [stamp, pose] : seen.poses) {
    const auto t = truth.find(stamp);
    ASSERT_NE(t, truth.end());
    EXPECT_LT((pose.translation() - t->second.to_isometry().translation()).norm(), 0.03) << "scan at " << stamp;
    EXPECT_NEAR(locd::yaw_of(pose.linear()), t->second.theta, 0.01);
  }
  EXPECT_EQ(seen.goal_plugin, "icp_explorer");
  const locd::ExplorationGoal& goal = seen.goals.back();
  EXPECT_FALSE(goal.done) << "room B is still unseen";
  EXPECT_GT(goal.score, 0.0);
  EXPECT_GT(goal.pose.translation().x(), -0.5);
  EXPECT_LT(goal.pose.translation().x(), 10.5);
  EXPECT_GT(seen.map_points, 500u);
  lock.unlock();

  while (save_requests.matched() == 0) {
    ASSERT_TRUE(std::chrono::steady_clock::now() < deadline + kTimeout) << "map save request not matched";
    std::this_thread::sleep_for(10ms);
  }
  locd_msg_MapSaveRequest save;
  std::memset(&save, 0, sizeof save);
  locd::dds::copy_string(save.robot_id, kRobot);
  save.request_id = 7;
  save_requests.write(save);
  lock.lock();
  ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] { return seen.request_id == 7; })) << locd.output();
  EXPECT_TRUE(seen.request_ok) << seen.message;
  EXPECT_EQ(seen.message.rfind("map saved to " + fs::canonical(dir / "maps").string() + "/scanner_bot_map_3scans_", 0), 0u)
      << seen.message;
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir / "maps")) files += entry.path().extension() == ".pcd";
  EXPECT_EQ(files, 1u);
  lock.unlock();
}

}  // namespace
