// emoi_markov inside a real locd over real DDS (loopback, domain 85): a robot starts an
// emoi_markov session on a small DSM (GeoTIFF in a map directory), streams odometry, IMU and
// tilting-laser scans from the simulator, and gets poses, the belief grid and diagnostics back;
// a scan with a NaN sensor pose is rejected with a clear error on its status, counted, and the
// session carries on.
#include <gtest/gtest.h>

#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "test_server.hpp"
#include "locd/dds/convert.hpp"
#include "locd/dds/topics.hpp"
#include "locd/sim_emoi_markov/four_positions.hpp"
#include "test_env.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::dds::QosProfile;
namespace sim = locd::sim::emoi;

constexpr int kDomain = 85;
constexpr auto kTimeout = 60s;

struct Seen {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::pair<int64_t, Eigen::Vector2d>> poses;
  size_t belief_grids = 0;
  uint32_t belief_width = 0, belief_height = 0;
  double belief_sum = 0.0;
  size_t diagnostics_with_coverage = 0;
  std::string diagnostics_plugin;
  uint64_t rejected = 0;
  std::string last_error, message;
  bool running = false;
};

TEST(EmoiMarkovOverDds, LocalizesFromScansAndRejectsABadScan) {
  // Maps come from the server folder's own maps/ (a relative map directory resolves there).
  locd::test::TestServer server("emoi_markov_dds", kDomain, {"maps", "", 2000});
  locd::test::ChildProcess& locd = server.process();
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


  Seen seen;
  locd::dds::Participant participant(kDomain);
  locd::dds::Writer<locd_msg_SessionRequest> requests(participant, locd::topics::kSessionRequest, QosProfile::kState);
  locd::dds::Writer<locd_msg_Odometry> odometry(participant, locd::topics::kOdometry, QosProfile::kSensor, 256);
  locd::dds::Writer<locd_msg_Imu> imu(participant, locd::topics::kImu, QosProfile::kSensor, 256);
  locd::dds::Writer<locd_msg_LaserScan> scans(participant, locd::topics::kScan, QosProfile::kSensor, 64);
  locd::dds::Reader<locd_msg_SessionStatus> statuses(
      participant, locd::topics::kSessionStatus, QosProfile::kState, [&](const locd_msg_SessionStatus& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.rejected = m.rejected;
        seen.last_error = locd::dds::to_string(m.last_error);
        seen.message = locd::dds::to_string(m.message);
        seen.running = m.state == locd_msg_STATE_RUNNING;
        seen.changed.notify_all();
      });
  locd::dds::Reader<locd_msg_PoseEstimate> poses(
      participant, locd::topics::kPose, QosProfile::kPose, [&](const locd_msg_PoseEstimate& m) {
        const locd::PoseEstimate p = locd::dds::from_wire(m);
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.poses.push_back({p.header.stamp_ns, p.pose.translation().head<2>()});
        seen.changed.notify_all();
      });
  locd::dds::Reader<locd_msg_GridMap> grids(
      participant, locd::topics::kGrid, QosProfile::kState, [&](const locd_msg_GridMap& m) {
        if (locd::dds::to_string(m.layer) != "belief") return;
        double sum = 0.0;
        for (uint32_t i = 0; i < m.cells._length; ++i) sum += m.cells._buffer[i];
        std::lock_guard<std::mutex> lock(seen.mutex);
        ++seen.belief_grids;
        seen.belief_width = m.width;
        seen.belief_height = m.height;
        seen.belief_sum = sum;
      });
  locd::dds::Reader<locd_msg_Diagnostics> diagnostics(
      participant, locd::topics::kDiagnostics, QosProfile::kSensor, [&](const locd_msg_Diagnostics& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        for (uint32_t i = 0; i < m.values._length; ++i) {
          if (locd::dds::to_string(m.values._buffer[i].name) == "coverage_r3") ++seen.diagnostics_with_coverage;
        }
        seen.diagnostics_plugin = locd::dds::to_string(m.plugin);
      }, 64);
  const auto deadline = std::chrono::steady_clock::now() + kTimeout;
  while (requests.matched() == 0 || odometry.matched() == 0 || scans.matched() == 0 || imu.matched() == 0 ||
         statuses.matched() == 0) {
    ASSERT_TRUE(std::chrono::steady_clock::now() < deadline && locd.running()) << "locd did not come up:\n" << locd.output();
    std::this_thread::sleep_for(10ms);
  }

  const std::string config =
      "plugin: emoi_markov\nparams:\n  map: small_world.tif\n  radii_m: [3, 6]\n  cache: false\n"
      "  update_distance_m: 8\n  heading_source: imu\n  match_resolution_m: 0.2\n  min_coverage: 0.05\n"
      "  full_coverage: 0.5\n  base_height_m: 0.4\n  local_map_size_m: 44\n";
  auto request = std::make_unique<locd_msg_SessionRequest>();
  std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
  locd::dds::copy_string(request->robot_id, "dsm_bot");
  request->request_id = 1;
  request->action = locd_msg_SESSION_START;
  locd::dds::copy_string(request->plugin, "emoi_markov");
  locd::dds::copy_string(request->config_yaml, config);
  requests.write(*request);
  {
    std::unique_lock<std::mutex> lock(seen.mutex);
    ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] { return seen.running; }))
        << "session not running: " << seen.message << "\n" << locd.output();
  }

  int64_t last_odometry_stamp = 0;
  bool bad_scan_sent = false;
  size_t poses_before_bad_scan = 0;
  sim::simulate_measurements(scenario, run, 11, [&](const locd::Measurement& m, const Eigen::Isometry3d&) {
    if (const auto* o = std::get_if<locd::Odometry>(&m)) {
      locd::dds::write(odometry, "dsm_bot", *o);
      last_odometry_stamp = o->header.stamp_ns;
    } else if (const auto* i = std::get_if<locd::Imu>(&m)) {
      locd::dds::write(imu, "dsm_bot", *i);
    } else if (const auto* s = std::get_if<locd::LaserScan>(&m)) {
      if (!bad_scan_sent && s->header.stamp_ns > 10'000'000'000) {
        locd::LaserScan bad = *s;
        bad.sensor_pose.translation().x() = std::nan("");
        locd::dds::write(scans, "dsm_bot", bad);
        bad_scan_sent = true;
        std::lock_guard<std::mutex> lock(seen.mutex);
        poses_before_bad_scan = seen.poses.size();
      } else {
        locd::dds::write(scans, "dsm_bot", *s);
      }
      std::this_thread::sleep_for(8ms);  // a robot's pace, compressed
    }
    return false;
  });

  std::unique_lock<std::mutex> lock(seen.mutex);
  ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] {
    return !seen.poses.empty() && seen.poses.back().first == last_odometry_stamp;
  })) << "no pose for the last odometry; poses " << seen.poses.size() << "\n" << locd.output();
  ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] { return seen.rejected >= 1; })) << locd.output();
  EXPECT_NE(seen.last_error.find("sensor_pose"), std::string::npos) << seen.last_error;
  EXPECT_GT(seen.poses.size(), poses_before_bad_scan) << "the session goes on after the bad scan";
  EXPECT_GE(seen.belief_grids, 2u);
  EXPECT_GT(seen.belief_width, 0u);
  EXPECT_NEAR(seen.belief_sum, 1.0, 1e-3);
  EXPECT_GE(seen.diagnostics_with_coverage, 2u);
  EXPECT_EQ(seen.diagnostics_plugin, "emoi_markov");
  for (const auto& [stamp, position] : seen.poses) EXPECT_TRUE(position.allFinite());
  lock.unlock();
}

}  // namespace
