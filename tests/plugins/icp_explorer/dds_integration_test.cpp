// icp_explorer inside a real locd over real DDS (loopback, domain 90): a robot starts an
// icp_explorer session with the toy two-room world's parameters, stops and scans three times
// with odometry in between, and gets a registered pose per scan near the truth, the registered
// map (transient-local) and an exploration goal; an all-NaN cloud is rejected with a clear error
// on its status, counted, and the session carries on; through the client library, an operator
// gets the same goals by callback and asks for the map to be saved (no path in the request): it
// is written into the server's output_directory and named on the answering status.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <map>
#include <random>
#include <thread>

#include "locd/client/client.hpp"
#include "robot_side.hpp"
#include "test_server.hpp"
#include "toy_world.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::dds::QosProfile;

constexpr int kDomain = 90;
const char* kRobot = "scanner_bot";

const std::string kPluginConfig = R"(plugin: icp_explorer
params:
  max_points: 50000
  rejection: {max_range: 15.0}
  exploration: {origin: [-0.5, -0.5], size: [11.0, 5.0], rays: 60, candidate_stride: 3, done_threshold: 2.0}
  map_output: {publish_every_scans: 1, publish_voxel_size: 0.3}
)";

TEST(IcpExplorerOverDds, RegistersScansPublishesMapAndGoalAndRejectsABadCloud) {
  locd::test::TestServer server("icp_explorer_dds", kDomain, {"", "output_directory: maps\n", 64});
  const fs::path& dir = server.dir();
  locd::test::RobotSide robot(kDomain, kRobot, server.process(), 60s);
  locd::dds::Participant& participant = robot.participant();
  locd::dds::Writer<locd_msg_InitialPose> initial_pose(participant, locd::topics::kInitialPose, QosProfile::kState, 8,
                                                       robot.partition());
  locd::dds::Writer<locd_msg_Odometry> odometry(participant, locd::topics::kOdometry, QosProfile::kSensor, 16, robot.partition());
  locd::dds::Writer<locd_msg_PointCloud> clouds(participant, locd::topics::kCloud, QosProfile::kSensor, 4, robot.partition());
  std::vector<locd::ExplorationGoal> goals_seen;
  std::string goal_plugin;
  size_t map_points = 0;
  locd::dds::Reader<locd_msg_ExplorationGoal> goals(
      participant, locd::topics::kExplorationGoal, QosProfile::kOutputState, [&](const locd_msg_ExplorationGoal& m) {
        const locd::ExplorationGoal g = locd::dds::from_wire(m);
        std::lock_guard<std::mutex> lock(robot.mutex());
        goals_seen.push_back(g);
        goal_plugin = locd::dds::to_string(m.plugin);
        robot.notify();
      }, 8, robot.partition());
  locd::dds::Reader<locd_msg_PointCloudMap> maps(
      participant, locd::topics::kMapCloud, QosProfile::kOutputState, [&](const locd_msg_PointCloudMap& m) {
        std::lock_guard<std::mutex> lock(robot.mutex());
        map_points = m.xyz._length / 3;
        robot.notify();
      }, 8, robot.partition());
  // An operator's program on the client library: the same goals by callback, and map saving.
  std::vector<locd::ExplorationGoalUpdate> client_goals;
  locd::Client operator_client({.domain_id = kDomain, .robot_id = kRobot});
  operator_client.on_exploration_goal(
      [&](const locd::ExplorationGoalUpdate& g) {
        std::lock_guard<std::mutex> lock(robot.mutex());
        client_goals.push_back(g);
        robot.notify();
      },
      kRobot);
  ASSERT_TRUE(robot.wait_matched(initial_pose, odometry, clouds));
  ASSERT_TRUE(robot.start("icp_explorer", kPluginConfig));
  const std::vector<locd::Pose2> stops = {{3.0, 1.2, 0.0}, {3.8, 1.5, 0.2}, {4.6, 2.0, 0.5}};
  locd::PoseEstimate start;
  start.header.stamp_ns = 500'000'000;
  start.pose = stops[0].to_isometry();
  locd::dds::write(initial_pose, kRobot, start);
  ASSERT_TRUE(robot.wait_initial_pose(start.header.stamp_ns));  // held before the first scan

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
    ASSERT_TRUE(robot.wait_pose(stamp)) << "scan " << k;
    if (k == 0) {
      // A cloud of NaN points between the scans: rejected, named, counted.
      locd::PointCloud bad;
      bad.header.stamp_ns = stamp + 1000;
      bad.points.assign(100, Eigen::Vector3f(NAN, NAN, NAN));
      locd::dds::write(clouds, kRobot, bad);
      ASSERT_TRUE(robot.wait_rejected(1));
      EXPECT_NE(robot.status_now().last_error.find("cloud"), std::string::npos) << robot.status_now().last_error;
    }
  }

  // The goal is state (transient-local, keep-last 1): a reader that matched the goal writer late
  // sees only the newest goal, so the test waits for the goal of the last scan, in both readers.
  const int64_t last_stamp = static_cast<int64_t>(stops.size()) * 1'000'000'000;
  auto lock = robot.lock();
  ASSERT_TRUE(robot.wait(lock,
                         [&] {
                           return !goals_seen.empty() && goals_seen.back().header.stamp_ns == last_stamp &&
                                  !client_goals.empty() && client_goals.back().goal.header.stamp_ns == last_stamp &&
                                  map_points > 0;
                         },
                         "the goal of the last scan (raw reader and client) and a map"))
      << "goals " << goals_seen.size() << ", client goals " << client_goals.size() << ", map points " << map_points;
  EXPECT_EQ(client_goals.back().plugin, "icp_explorer");
  EXPECT_EQ(client_goals.back().goal.header.stamp_ns, goals_seen.back().header.stamp_ns);
  EXPECT_TRUE(client_goals.back().goal.pose.isApprox(goals_seen.back().pose));
  size_t compared = 0;
  for (const locd::PoseEstimate& p : robot.poses()) {
    const auto t = truth.find(p.header.stamp_ns);
    ASSERT_NE(t, truth.end());
    ++compared;
    EXPECT_LT((p.pose.translation() - t->second.to_isometry().translation()).norm(), 0.03) << "scan at " << t->first;
    EXPECT_NEAR(locd::yaw_of(p.pose.linear()), t->second.theta, 0.01);
  }
  EXPECT_EQ(compared, stops.size());
  EXPECT_EQ(goal_plugin, "icp_explorer");
  const locd::ExplorationGoal& goal = goals_seen.back();
  EXPECT_FALSE(goal.done) << "room B is still unseen";
  EXPECT_GT(goal.score, 0.0);
  EXPECT_GT(goal.pose.translation().x(), -0.5);
  EXPECT_LT(goal.pose.translation().x(), 10.5);
  EXPECT_GT(map_points, 500u);
  lock.unlock();

  // A map save request through the client library (no path in it): written into the server's
  // output directory, the file named on the status that answers it.
  const auto saved = operator_client.save_map(60s);
  ASSERT_TRUE(saved) << "no answer to the map save request";
  EXPECT_TRUE(saved->request_ok) << saved->message;
  EXPECT_EQ(saved->message.rfind("map saved to " + fs::canonical(dir / "maps").string() + "/scanner_bot_map_3scans_", 0), 0u)
      << saved->message;
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir / "maps")) files += entry.path().extension() == ".pcd";
  EXPECT_EQ(files, 1u);
}

}  // namespace
