// ceiling_pf inside a real locd over real DDS (loopback, domain 80): a robot starts a ceiling_pf
// session, streams odometry and rendered camera frames of the hall, and gets poses near the
// truth and particle diagnostics back; a wrong-size frame is rejected with a clear error on its
// status, counted, and the session carries on.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <thread>

#include "locd/sim_ceiling_pf/hall_drive.hpp"
#include "robot_side.hpp"
#include "test_server.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::dds::QosProfile;
namespace simc = locd::sim::ceiling;

constexpr int kDomain = 80;

TEST(CeilingPfOverDds, TracksFromCameraFramesAndRejectsABadFrame) {
  locd::test::TestServer server("ceiling_pf_dds", kDomain);
  locd::test::RobotSide robot(kDomain, "hall_bot", server.process());
  locd::dds::Writer<locd_msg_Odometry> odometry(robot.participant(), locd::topics::kOdometry, QosProfile::kSensor, 64, robot.partition());
  locd::dds::Writer<locd_msg_Image> images(robot.participant(), locd::topics::kImage, QosProfile::kSensor, 16, robot.partition());
  size_t diagnostics_with_particles = 0;
  std::string diagnostics_plugin;
  locd::dds::Reader<locd_msg_Diagnostics> diagnostics(
      robot.participant(), locd::topics::kDiagnostics, QosProfile::kOutput, [&](const locd_msg_Diagnostics& m) {
        std::lock_guard<std::mutex> lock(robot.mutex());
        if (m.particles._length > 0) ++diagnostics_with_particles;
        diagnostics_plugin = locd::dds::to_string(m.plugin);
      }, 64, robot.partition());
  ASSERT_TRUE(robot.wait_matched(odometry, images));

  // The world of the scenario, the shipped plugin config with the start pose added.
  const locd::Params scenario = locd::Params::load_file(locd::test::source_dir() + "/config/scenarios/ceiling_hall.yaml");
  const locd::Params cam = scenario.child("sensors").child("ceiling_camera");
  const simc::CeilingWorld world(simc::CeilingWorldConfig::from_params(cam.child("world")));
  const simc::CeilingCameraRenderer renderer(simc::CeilingCameraConfig::from_params(cam), world);
  simc::HallDrive drive(simc::DriveConfig{}, renderer, 8);
  const locd::Pose2 start = drive.truth().pose;
  std::string config = locd::test::read_text(fs::path(locd::test::source_dir()) / "config/plugins/ceiling_pf.yaml");
  const std::string marker = "# initial_pose: [30.38, 27.2, 0.0]";
  config.replace(config.find(marker), marker.size(),
                 "initial_pose: [" + std::to_string(start.x) + ", " + std::to_string(start.y) + ", " +
                     std::to_string(start.theta) + "]");
  ASSERT_TRUE(robot.start("ceiling_pf", config));

  std::map<int64_t, locd::Pose2> truth;
  auto stream = [&](double until) {
    while (auto e = drive.next(until)) {
      if (const auto* o = std::get_if<locd::Odometry>(&e->measurement)) {
        locd::dds::write(odometry, robot.robot_id(), *o);
        truth[o->header.stamp_ns] = e->truth;
      } else if (const auto* img = std::get_if<locd::Image>(&e->measurement)) {
        locd::dds::write(images, robot.robot_id(), *img);
        truth[img->header.stamp_ns] = e->truth;
      }
      std::this_thread::sleep_for(3ms);  // a robot's pace, compressed
    }
  };
  stream(15.0);

  // A frame of the wrong size: rejected, named, counted.
  locd::Image small;
  small.header.stamp_ns = truth.rbegin()->first + 1;
  small.width = 320;
  small.height = 240;
  small.data.assign(320 * 240, 90);
  locd::dds::write(images, robot.robot_id(), small);
  ASSERT_TRUE(robot.wait_rejected(1));
  EXPECT_NE(robot.status_now().last_error.find("640 x 480"), std::string::npos) << robot.status_now().last_error;
  const size_t poses_before = robot.pose_count();
  stream(25.0);
  const int64_t last_stamp = truth.rbegin()->first;
  ASSERT_TRUE(robot.wait_pose(last_stamp));
  auto lock = robot.lock();
  const auto& poses = robot.poses();
  EXPECT_GT(poses.size(), poses_before) << "the session goes on after the bad frame";
  EXPECT_GT(diagnostics_with_particles, 10u);
  EXPECT_EQ(diagnostics_plugin, "ceiling_pf");
  double max_error = 0.0;
  for (const locd::PoseEstimate& p : poses) {
    const auto t = truth.find(p.header.stamp_ns);
    if (t == truth.end()) continue;
    max_error = std::max(max_error, std::hypot(p.pose.translation().x() - t->second.x, p.pose.translation().y() - t->second.y));
  }
  EXPECT_LT(max_error, 0.25);
  const locd::PoseEstimate& last = poses.back();
  EXPECT_EQ(last.header.stamp_ns, last_stamp);
  EXPECT_LT(std::hypot(last.pose.translation().x() - truth.rbegin()->second.x,
                       last.pose.translation().y() - truth.rbegin()->second.y), 0.1);
}

}  // namespace
