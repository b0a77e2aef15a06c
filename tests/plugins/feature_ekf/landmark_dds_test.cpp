// feature_ekf's landmark model inside a real locd over real DDS (loopback, domain 95): a car
// starts a session with the shipped road-sign config, streams IMU samples and sign detections of
// a short simulated drive, and gets poses near the truth with velocity, and association records
// on the diagnostics topic; a detection of an unknown class is rejected with a clear error on its
// status, counted, and the session carries on.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <thread>

#include "locd/sim_feature_ekf/road_sign_drive.hpp"
#include "robot_side.hpp"
#include "test_server.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::dds::QosProfile;
namespace rs = locd::sim::road_signs;

constexpr int kDomain = 95;

void replace_line(std::string& text, const std::string& key, const std::string& line) {
  const size_t at = text.find("  " + key + ":");
  ASSERT_NE(at, std::string::npos) << key;
  text.replace(at, text.find('\n', at) - at, line);
}

TEST(FeatureEkfLandmarksOverDds, TracksARoadSignDriveAndRejectsAnUnknownClass) {
  locd::test::TestServer server("feature_ekf_landmarks_dds", kDomain);
  locd::test::RobotSide robot(kDomain, "sign_car", server.process());
  locd::dds::Writer<locd_msg_Imu> imu_writer(robot.participant(), locd::topics::kImu, QosProfile::kSensor, 256, robot.partition());
  locd::dds::Writer<locd_msg_LandmarkDetections> detections(robot.participant(), locd::topics::kDetections,
                                                            QosProfile::kSensor, 16, robot.partition());
  size_t associated = 0, records = 0;
  std::string diagnostics_plugin;
  locd::dds::Reader<locd_msg_Diagnostics> diagnostics(
      robot.participant(), locd::topics::kDiagnostics, QosProfile::kOutput, [&](const locd_msg_Diagnostics& m) {
        std::lock_guard<std::mutex> lock(robot.mutex());
        diagnostics_plugin = locd::dds::to_string(m.plugin);
        for (uint32_t i = 0; i < m.associations._length; ++i) {
          ++records;
          if (locd::dds::to_string(m.associations._buffer[i].feature_id).size() > 0) ++associated;
        }
      }, 64, robot.partition());
  ASSERT_TRUE(robot.wait_matched(imu_writer, detections));

  // The scenario's world (its database is config/maps/road_signs.csv), a 40 s drive with the
  // IMU at 100 Hz to keep the test short; the shipped config with the start filled in.
  const locd::Params scenario = locd::Params::load_file(locd::test::source_dir() + "/config/scenarios/road_signs.yaml");
  const rs::RoadSignWorld world(rs::WorldConfig::from_params(scenario.child("world")));
  rs::DriveConfig drive_config;
  drive_config.duration = 40.0;
  drive_config.imu_rate = 100.0;
  rs::RoadSignDrive drive(world, drive_config, 5, 2);
  std::string config = locd::test::read_text(fs::path(locd::test::source_dir()) / "config/plugins/feature_ekf_road_signs.yaml");
  const rs::DriveTruth start = drive.truth();
  replace_line(config, "initial_position", "  initial_position: [" + std::to_string(start.position.x() + 2.0) + ", " +
                                               std::to_string(start.position.y() - 2.0) + "]");
  replace_line(config, "initial_velocity", "  initial_velocity: [" + std::to_string(start.velocity.x()) + ", " +
                                               std::to_string(start.velocity.y()) + "]");
  replace_line(config, "velocity_noise_per_step", "  velocity_noise_per_step: 0.01");
  ASSERT_TRUE(robot.start("feature_ekf", config));

  std::map<int64_t, rs::DriveTruth> truth;
  int64_t last_stamp = 0;
  auto stream = [&](double until) {
    while (auto e = drive.next(until)) {
      if (const auto* imu = std::get_if<locd::Imu>(&e->measurement)) {
        locd::dds::write(imu_writer, robot.robot_id(), *imu);
        std::this_thread::sleep_for(500us);
      } else if (const auto* frame = std::get_if<locd::LandmarkDetections>(&e->measurement)) {
        locd::dds::write(detections, robot.robot_id(), *frame);
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
  locd::dds::write(detections, robot.robot_id(), bad);
  ASSERT_TRUE(robot.wait_rejected(1));
  EXPECT_NE(robot.status_now().last_error.find("class 'stop_sign' is not in the landmark database"), std::string::npos)
      << robot.status_now().last_error;
  const size_t poses_before = robot.pose_count();
  stream(40.0);
  ASSERT_TRUE(robot.wait_pose(last_stamp));
  auto lock = robot.lock();
  const auto& poses = robot.poses();
  EXPECT_GT(poses.size(), poses_before) << "the session goes on after the bad detection";
  EXPECT_EQ(diagnostics_plugin, "feature_ekf");
  EXPECT_GT(records, 5u);
  EXPECT_GT(associated, 5u);
  double max_error = 0.0;
  size_t compared = 0;
  for (const locd::PoseEstimate& p : poses) {
    const auto t = truth.find(p.header.stamp_ns);
    if (t == truth.end()) continue;
    ++compared;
    max_error = std::max(max_error, (p.pose.translation().head<2>() - t->second.position).norm());
    EXPECT_LT((p.linear_velocity.head<2>() - t->second.velocity).norm(), 2.0);
  }
  EXPECT_GT(compared, 30u);
  EXPECT_LT(max_error, 15.0);
}

}  // namespace
