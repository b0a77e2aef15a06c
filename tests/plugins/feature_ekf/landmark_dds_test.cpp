// feature_ekf's landmark model inside a real locd over real DDS (loopback, domain 95): a car
// starts a session with the shipped road-sign config, streams IMU samples and sign detections of
// a short simulated drive, and gets poses near the truth with velocity, and association records
// on the diagnostics topic; a detection of an unknown class is rejected with a clear error on its
// status, counted, and the session carries on.
#include <gtest/gtest.h>

#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

#include "test_server.hpp"
#include "locd/dds/convert.hpp"
#include "locd/dds/topics.hpp"
#include "locd/sim_feature_ekf/road_sign_drive.hpp"
#include "test_env.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::dds::QosProfile;
namespace rs = locd::sim::road_signs;

constexpr int kDomain = 95;
constexpr auto kTimeout = 30s;

struct Seen {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<locd::PoseEstimate> poses;
  size_t associated = 0, records = 0;
  std::string diagnostics_plugin;
  uint64_t rejected = 0;
  std::string last_error, message;
  bool running = false;
};

std::string read(const fs::path& f) {
  std::ifstream in(f);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void replace_line(std::string& text, const std::string& key, const std::string& line) {
  const size_t at = text.find("  " + key + ":");
  ASSERT_NE(at, std::string::npos) << key;
  text.replace(at, text.find('\n', at) - at, line);
}

TEST(FeatureEkfLandmarksOverDds, TracksARoadSignDriveAndRejectsAnUnknownClass) {
  locd::test::TestServer server("feature_ekf_landmarks_dds", kDomain);
  locd::test::ChildProcess& locd = server.process();
  Seen seen;
  locd::dds::Participant participant(kDomain);
  locd::dds::Writer<locd_msg_SessionRequest> requests(participant, locd::topics::kSessionRequest, QosProfile::kState);
  locd::dds::Writer<locd_msg_Imu> imu_writer(participant, locd::topics::kImu, QosProfile::kSensor, 256);
  locd::dds::Writer<locd_msg_LandmarkDetections> detections(participant, locd::topics::kDetections, QosProfile::kSensor, 16);
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
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.poses.push_back(locd::dds::from_wire(m));
        seen.changed.notify_all();
      });
  locd::dds::Reader<locd_msg_Diagnostics> diagnostics(
      participant, locd::topics::kDiagnostics, QosProfile::kSensor, [&](const locd_msg_Diagnostics& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.diagnostics_plugin = locd::dds::to_string(m.plugin);
        for (uint32_t i = 0; i < m.associations._length; ++i) {
          ++seen.records;
          if (locd::dds::to_string(m.associations._buffer[i].feature_id).size() > 0) ++seen.associated;
        }
      }, 64);
  const auto deadline = std::chrono::steady_clock::now() + kTimeout;
  while (requests.matched() == 0 || imu_writer.matched() == 0 || detections.matched() == 0 || statuses.matched() == 0) {
    ASSERT_TRUE(std::chrono::steady_clock::now() < deadline && locd.running()) << "locd did not come up:\n" << locd.output();
    std::this_thread::sleep_for(10ms);
  }

  // The scenario's world (its database is config/maps/road_signs.csv), a 40 s drive with the
  // IMU at 100 Hz to keep the test short; the shipped config with the start filled in.
  const locd::Params scenario = locd::Params::load_file(locd::test::source_dir() + "/config/scenarios/road_signs.yaml");
  const rs::RoadSignWorld world(rs::WorldConfig::from_params(scenario.child("world")));
  rs::DriveConfig drive_config;
  drive_config.duration = 40.0;
  drive_config.imu_rate = 100.0;
  rs::RoadSignDrive drive(world, drive_config, 5, 2);
  std::string config = read(fs::path(locd::test::source_dir()) / "config/plugins/feature_ekf_road_signs.yaml");
  const rs::DriveTruth start = drive.truth();
  replace_line(config, "initial_position", "  initial_position: [" + std::to_string(start.position.x() + 2.0) + ", " +
                                               std::to_string(start.position.y() - 2.0) + "]");
  replace_line(config, "initial_velocity", "  initial_velocity: [" + std::to_string(start.velocity.x()) + ", " +
                                               std::to_string(start.velocity.y()) + "]");
  replace_line(config, "velocity_noise_per_step", "  velocity_noise_per_step: 0.01");
  auto request = std::make_unique<locd_msg_SessionRequest>();
  std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
  locd::dds::copy_string(request->robot_id, "sign_car");
  request->request_id = 1;
  request->action = locd_msg_SESSION_START;
  locd::dds::copy_string(request->plugin, "feature_ekf");
  locd::dds::copy_string(request->config_yaml, config);
  requests.write(*request);
  {
    std::unique_lock<std::mutex> lock(seen.mutex);
    ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] { return seen.running; }))
        << "session not running: " << seen.message << "\n" << locd.output();
  }

  std::map<int64_t, rs::DriveTruth> truth;
  int64_t last_stamp = 0;
  auto stream = [&](double until) {
    while (auto e = drive.next(until)) {
      if (const auto* imu = std::get_if<locd::Imu>(&e->measurement)) {
        locd::dds::write(imu_writer, "sign_car", *imu);
        std::this_thread::sleep_for(500us);
      } else if (const auto* frame = std::get_if<locd::LandmarkDetections>(&e->measurement)) {
        locd::dds::write(detections, "sign_car", *frame);
        truth[frame->header.stamp_ns] = e->truth;
        last_stamp = frame->header.stamp_ns;
        std::this_thread::sleep_for(2ms);
      }
    }
  };
  stream(20.0);

  // A stop sign: not in the database. Rejected, named, counted.
  locd::LandmarkDetections bad;
  bad.header.stamp_ns = last_stamp + 1;
  bad.detections.push_back({"stop_sign", {15.0, 3.0, 0.0}, Eigen::Matrix3d::Identity()});
  locd::dds::write(detections, "sign_car", bad);
  {
    std::unique_lock<std::mutex> lock(seen.mutex);
    ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] { return seen.rejected >= 1; })) << locd.output();
    EXPECT_NE(seen.last_error.find("class 'stop_sign' is not in the landmark database"), std::string::npos)
        << seen.last_error;
  }
  const size_t poses_before = [&] {
    std::lock_guard<std::mutex> lock(seen.mutex);
    return seen.poses.size();
  }();
  stream(40.0);
  std::unique_lock<std::mutex> lock(seen.mutex);
  ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] {
    return !seen.poses.empty() && seen.poses.back().header.stamp_ns == last_stamp;
  })) << "no pose for the last frame; poses " << seen.poses.size() << "\n" << locd.output();
  EXPECT_GT(seen.poses.size(), poses_before) << "the session goes on after the bad detection";
  EXPECT_EQ(seen.diagnostics_plugin, "feature_ekf");
  EXPECT_GT(seen.records, 5u);
  EXPECT_GT(seen.associated, 5u);
  double max_error = 0.0;
  size_t compared = 0;
  for (const locd::PoseEstimate& p : seen.poses) {
    const auto t = truth.find(p.header.stamp_ns);
    if (t == truth.end()) continue;
    ++compared;
    max_error = std::max(max_error, (p.pose.translation().head<2>() - t->second.position).norm());
    EXPECT_LT((p.linear_velocity.head<2>() - t->second.velocity).norm(), 2.0);
  }
  EXPECT_GT(compared, 30u);
  EXPECT_LT(max_error, 15.0);
  lock.unlock();
}

}  // namespace
