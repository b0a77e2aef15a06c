// grid_mcl inside a real locd over real DDS (loopback, domain 130): a robot starts a grid_mcl session
// on the corridor grid, streams the simulated odometry and 541-beam scans, and gets poses near the
// truth, the localization state "tracking" on its status and the map on the grid topic. A second
// robot names a map whose PGM is shorter than its header: its request fails with the file named,
// and the first robot's session carries on; a scan longer than the server's limit is refused
// naming limits.max_scan_beams.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "locd/sim/scenario.hpp"
#include "locd/sim/simulation.hpp"
#include "robot_side.hpp"
#include "test_server.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::dds::QosProfile;

constexpr int kDomain = 130;

TEST(GridMclOverDds, TracksOnTheCorridorGridAndABadMapCostsOnlyItsRobot) {
  const fs::path extra_maps = fs::temp_directory_path() / ("grid_mcl_dds_maps_" + std::to_string(::getpid()));
  fs::create_directories(extra_maps);
  std::ofstream(extra_maps / "truncated.pgm", std::ios::binary) << "P5\n40 30\n255\n" << std::string(1000, '\xfe');
  std::ofstream(extra_maps / "truncated.yaml") << "image: truncated.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n";
  locd::test::TestServerOptions options;
  options.map_directories = locd::test::source_dir() + "/config/maps, " + extra_maps.string();
  options.extra_config = "limits: {max_scan_beams: 600}\n";
  locd::test::TestServer server("grid_mcl_dds", kDomain, options);

  locd::test::RobotSide robot(kDomain, "grid_bot", server.process());
  locd::dds::Writer<locd_msg_Odometry> odometry(robot.participant(), locd::topics::kOdometry, QosProfile::kSensor, 64,
                                                robot.partition());
  locd::dds::Writer<locd_msg_LaserScan> scans(robot.participant(), locd::topics::kScan, QosProfile::kSensor, 16,
                                              robot.partition());
  int grid_width = 0, grid_height = 0;
  size_t grid_cells = 0;
  locd::dds::Reader<locd_msg_GridMap> grids(
      robot.participant(), locd::topics::kGrid, QosProfile::kOutputState,
      [&](const locd_msg_GridMap& m) {
        std::lock_guard<std::mutex> lock(robot.mutex());
        if (locd::dds::to_string(m.layer) != "occupancy") return;
        grid_width = static_cast<int>(m.width);
        grid_height = static_cast<int>(m.height);
        grid_cells = m.cells._length;
        robot.notify();
      },
      8, robot.partition());
  ASSERT_TRUE(robot.wait_matched(odometry, scans));

  // The scenario's robot, its plugin config with the true start pose set.
  const locd::sim::Scenario scenario =
      locd::sim::load_scenario(fs::path(locd::test::source_dir()) / "config/scenarios/corridor_grid.yaml");
  locd::sim::Simulation simulation(scenario, 5, 30.0);
  const locd::Pose2 start = simulation.truth().at(0.0).pose;
  std::string config = scenario.localizer.config_text;
  const std::string marker = "  set_initial_pose: false\n  # initial_pose: {x: 3.0, y: 1.0, z: 0.0, yaw: 0.0}";
  ASSERT_NE(config.find(marker), std::string::npos);
  config.replace(config.find(marker), marker.size(),
                 "  set_initial_pose: true\n  initial_pose: {x: " + std::to_string(start.x) + ", y: " +
                     std::to_string(start.y) + ", yaw: " + std::to_string(start.theta) + "}");
  ASSERT_TRUE(robot.start("grid_mcl", config));

  std::map<int64_t, locd::Pose2> truth;
  int64_t last_stamp = 0;
  auto stream = [&](double until) {
    while (auto m = simulation.next()) {
      if (const auto* o = std::get_if<locd::Odometry>(&m->measurement)) {
        locd::dds::write(odometry, robot.robot_id(), *o);
      } else if (const auto* s = std::get_if<locd::LaserScan>(&m->measurement)) {
        locd::dds::write(scans, robot.robot_id(), *s);
      }
      last_stamp = locd::header_of(m->measurement).stamp_ns;
      truth[last_stamp] = simulation.truth().at(m->t).pose;
      std::this_thread::sleep_for(2ms);  // a robot's pace, compressed
      if (m->t >= until) return;
    }
  };
  stream(8.0);

  // A second robot names a map whose image is shorter than its header.
  locd::test::RobotSide other(kDomain, "broken_bot", server.process());
  ASSERT_TRUE(other.wait_matched());
  auto request = std::make_unique<locd_msg_SessionRequest>();
  std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
  {
    locd::dds::Writer<locd_msg_SessionRequest> requests(other.participant(), locd::topics::kSessionRequest,
                                                        QosProfile::kState, 8, other.partition());
    ASSERT_TRUE(other.wait_matched(requests));
    locd::dds::copy_string(request->robot_id, "broken_bot");
    request->request_id = 7;
    request->action = locd_msg_SESSION_START;
    locd::dds::copy_string(request->plugin, "grid_mcl");
    const std::string config = "plugin: grid_mcl\nparams:\n  map: truncated.yaml\n";
    locd::dds::borrow_text(request->config_yaml, config, locd::topics::kMaxConfigYamlBytes);
    requests.write(*request);
    auto lock = other.lock();
    ASSERT_TRUE(other.wait(lock, [&] { return other.status().request_id == 7 && !other.status().request_ok &&
                                              !other.status().message.empty(); },
                           "the refused request"));
    EXPECT_NE(other.status().message.find("truncated.pgm"), std::string::npos) << other.status().message;
    EXPECT_NE(other.status().message.find("bytes of pixel data"), std::string::npos) << other.status().message;
  }

  // A scan longer than the server allows: refused before it is converted, named.
  locd::LaserScan too_long;
  too_long.header.stamp_ns = last_stamp + 1;
  too_long.angle_min = -1.0f;
  too_long.angle_increment = 0.001f;
  too_long.range_min = 0.1f;
  too_long.range_max = 30.0f;
  too_long.ranges.assign(700, 2.0f);
  locd::dds::write(scans, robot.robot_id(), too_long);
  ASSERT_TRUE(robot.wait_rejected(1));
  EXPECT_NE(robot.status_now().last_error.find("max_scan_beams"), std::string::npos) << robot.status_now().last_error;

  const size_t poses_before = robot.pose_count();
  stream(16.0);
  ASSERT_TRUE(robot.wait_pose(last_stamp));
  {
    auto lock = robot.lock();
    ASSERT_TRUE(robot.wait(lock, [&] { return grid_cells > 0; }, "the occupancy grid"));
    EXPECT_EQ(static_cast<size_t>(grid_width) * grid_height, grid_cells);
    EXPECT_GT(robot.poses().size(), poses_before) << "the session goes on after the other robot's bad map";
    double max_error = 0.0;
    size_t scored = 0;
    for (const locd::PoseEstimate& p : robot.poses()) {
      const auto t = truth.find(p.header.stamp_ns);
      if (t == truth.end() || p.header.stamp_ns < truth.begin()->first + 3'000'000'000) continue;
      max_error = std::max(max_error, std::hypot(p.pose.translation().x() - t->second.x, p.pose.translation().y() - t->second.y));
      ++scored;
    }
    EXPECT_GT(scored, 200u);
    EXPECT_LT(max_error, 0.15);
    EXPECT_EQ(robot.status().localization, "tracking") << robot.status().localization_reason;
    EXPECT_NE(robot.status().localization_reason.find("scan fit"), std::string::npos);
  }
  fs::remove_all(extra_maps);
}

}  // namespace
