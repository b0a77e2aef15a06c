// emoi_markov inside a real locd over real DDS (loopback, domain 85): a robot starts an
// emoi_markov session on a small DSM (GeoTIFF in a map directory), streams odometry, IMU and
// tilting-laser scans from the simulator, and gets poses, the belief grid and diagnostics back;
// a scan with a NaN sensor pose is rejected with a clear error on its status, counted, and the
// session carries on. The plugin's localization state reaches the robot's status: lost from the
// start (global belief, no sensor update yet), then judged by the sensor updates, with the
// criterion that decided it.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <thread>

#include "locd/emoi_markov/dsm_writer.hpp"
#include "locd/sim_emoi_markov/four_positions.hpp"
#include "robot_side.hpp"
#include "test_server.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::dds::QosProfile;
namespace sim = locd::sim::emoi;

constexpr int kDomain = 85;

TEST(EmoiMarkovOverDds, LocalizesFromScansAndRejectsABadScan) {
  // Maps come from the server folder's own maps/ (a relative map directory resolves there).
  locd::test::TestServer server("emoi_markov_dds", kDomain, {"maps", "", 2000});
  const fs::path& dir = server.dir();
  sim::FourPositionsScenario scenario;
  scenario.world.size_x_m = scenario.world.size_y_m = 60.0;
  scenario.world.resolution_m = 0.2;
  scenario.world.buildings = 4;
  scenario.world.walls = 4;
  scenario.world.trees = 10;
  scenario.path = {{15, 20}, {27, 20}, {35, 30}};
  scenario.laser.rate_hz = 5.0;
  scenario.laser.beams = 91;
  scenario.odometry.scale_stddev = 0.03;
  scenario.odometry.drift_stddev_rad = 0.01;
  const auto run = sim::build_run(scenario, 11);
  locd::emoi::write_dsm_geotiff(run.dsm, dir / "maps" / "small_world.tif");


  locd::test::RobotSide robot(kDomain, "dsm_bot", server.process(), 60s);
  locd::dds::Writer<locd_msg_Odometry> odometry(robot.participant(), locd::topics::kOdometry, QosProfile::kSensor, 256, robot.partition());
  locd::dds::Writer<locd_msg_Imu> imu(robot.participant(), locd::topics::kImu, QosProfile::kSensor, 256, robot.partition());
  locd::dds::Writer<locd_msg_LaserScan> scans(robot.participant(), locd::topics::kScan, QosProfile::kSensor, 64, robot.partition());
  size_t belief_grids = 0;
  uint32_t belief_width = 0;
  double belief_sum = 0.0;
  size_t diagnostics_with_coverage = 0;
  std::string diagnostics_plugin;
  locd::dds::Reader<locd_msg_GridMap> grids(
      robot.participant(), locd::topics::kGrid, QosProfile::kOutputState, [&](const locd_msg_GridMap& m) {
        if (locd::dds::to_string(m.layer) != "belief") return;
        double sum = 0.0;
        for (uint32_t i = 0; i < m.cells._length; ++i) sum += m.cells._buffer[i];
        std::lock_guard<std::mutex> lock(robot.mutex());
        ++belief_grids;
        belief_width = m.width;
        belief_sum = sum;
      }, 8, robot.partition());
  locd::dds::Reader<locd_msg_Diagnostics> diagnostics(
      robot.participant(), locd::topics::kDiagnostics, QosProfile::kOutput, [&](const locd_msg_Diagnostics& m) {
        std::lock_guard<std::mutex> lock(robot.mutex());
        for (uint32_t i = 0; i < m.values._length; ++i) {
          if (locd::dds::to_string(m.values._buffer[i].name) == "coverage_r3") ++diagnostics_with_coverage;
        }
        diagnostics_plugin = locd::dds::to_string(m.plugin);
      }, 64, robot.partition());
  ASSERT_TRUE(robot.wait_matched(odometry, imu, scans));

  const std::string config =
      "plugin: emoi_markov\nparams:\n  map: small_world.tif\n  radii_m: [3, 6]\n  cache: false\n"
      "  update_distance_m: 8\n  heading_source: imu\n  match_resolution_m: 0.2\n  min_coverage: 0.05\n"
      "  full_coverage: 0.5\n  base_height_m: 0.4\n  local_map_size_m: 44\n";
  ASSERT_TRUE(robot.start("emoi_markov", config));

  int64_t last_odometry_stamp = 0;
  bool bad_scan_sent = false;
  bool start_state_seen = false;
  std::string start_state, start_reason;
  size_t poses_before_bad_scan = 0;
  sim::simulate_measurements(scenario, run, 11, [&](const locd::Measurement& m, const Eigen::Isometry3d&) {
    if (const auto* o = std::get_if<locd::Odometry>(&m)) {
      locd::dds::write(odometry, robot.robot_id(), *o);
      last_odometry_stamp = o->header.stamp_ns;
      if (!start_state_seen && o->header.stamp_ns > 1'000'000'000) {  // 1 m driven: no sensor update yet
        start_state_seen = true;
        auto lock = robot.lock();
        EXPECT_TRUE(robot.wait(lock, [&] { return robot.status().localization != "unknown"; }, "a localization state"));
        start_state = robot.status().localization;
        start_reason = robot.status().localization_reason;
      }
    } else if (const auto* i = std::get_if<locd::Imu>(&m)) {
      locd::dds::write(imu, robot.robot_id(), *i);
    } else if (const auto* s = std::get_if<locd::LaserScan>(&m)) {
      if (!bad_scan_sent && s->header.stamp_ns > 10'000'000'000) {
        locd::LaserScan bad = *s;
        bad.sensor_pose.translation().x() = std::nan("");
        locd::dds::write(scans, robot.robot_id(), bad);
        bad_scan_sent = true;
        poses_before_bad_scan = robot.pose_count();
      } else {
        locd::dds::write(scans, robot.robot_id(), *s);
      }
      std::this_thread::sleep_for(8ms);  // a robot's pace, compressed
    }
    return false;
  });

  ASSERT_TRUE(robot.wait_pose(last_odometry_stamp));
  ASSERT_TRUE(robot.wait_rejected(1));
  auto lock = robot.lock();
  EXPECT_NE(robot.status().last_error.find("sensor_pose"), std::string::npos) << robot.status().last_error;
  EXPECT_GT(robot.poses().size(), poses_before_bad_scan) << "the session goes on after the bad scan";
  EXPECT_GE(belief_grids, 2u);
  EXPECT_GT(belief_width, 0u);
  EXPECT_NEAR(belief_sum, 1.0, 1e-3);
  EXPECT_GE(diagnostics_with_coverage, 2u);
  EXPECT_EQ(diagnostics_plugin, "emoi_markov");
  for (const locd::PoseEstimate& p : robot.poses()) EXPECT_TRUE(p.pose.translation().allFinite());
  EXPECT_EQ(start_state, "lost") << start_reason;
  EXPECT_NE(start_reason.find("no sensor update yet"), std::string::npos) << start_reason;
  // After the sensor updates: judged by a criterion of the README (modes, peak mass, area, fit).
  const std::string& state = robot.status().localization;
  const std::string& reason = robot.status().localization_reason;
  EXPECT_TRUE(state == "tracking" || state == "uncertain" || state == "lost") << state;
  EXPECT_EQ(reason.find("no sensor update yet"), std::string::npos) << reason;
  EXPECT_TRUE(reason.find("mode") != std::string::npos || reason.find("belief") != std::string::npos ||
              reason.find("fits") != std::string::npos)
      << reason;
}

}  // namespace
