// ceiling_pf inside a real locd over real DDS (loopback, domain 80): a robot starts a ceiling_pf
// session, streams odometry and rendered camera frames of the hall, and gets poses near the
// truth and particle diagnostics back; a wrong-size frame is rejected with a clear error on its
// status, counted, and the session carries on.
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
#include "locd/sim_ceiling_pf/hall_drive.hpp"
#include "test_env.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::dds::QosProfile;
namespace simc = locd::sim::ceiling;

constexpr int kDomain = 80;
constexpr auto kTimeout = 30s;

struct Seen {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::pair<int64_t, locd::Pose2>> poses;
  size_t diagnostics_with_particles = 0;
  std::string diagnostics_plugin;
  uint64_t rejected = 0, updates = 0;
  std::string last_error, message;
  bool running = false;
};

std::string read(const fs::path& f) {
  std::ifstream in(f);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(CeilingPfOverDds, TracksFromCameraFramesAndRejectsABadFrame) {
  locd::test::TestServer server("ceiling_pf_dds", kDomain);
  locd::test::ChildProcess& locd = server.process();

  Seen seen;
  locd::dds::Participant participant(kDomain);
  locd::dds::Writer<locd_msg_SessionRequest> requests(participant, locd::topics::kSessionRequest, QosProfile::kState);
  locd::dds::Writer<locd_msg_Odometry> odometry(participant, locd::topics::kOdometry, QosProfile::kSensor, 64);
  locd::dds::Writer<locd_msg_Image> images(participant, locd::topics::kImage, QosProfile::kSensor, 16);
  locd::dds::Reader<locd_msg_SessionStatus> statuses(
      participant, locd::topics::kSessionStatus, QosProfile::kState, [&](const locd_msg_SessionStatus& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.rejected = m.rejected;
        seen.updates = m.updates;
        seen.last_error = locd::dds::to_string(m.last_error);
        seen.message = locd::dds::to_string(m.message);
        seen.running = m.state == locd_msg_STATE_RUNNING;
        seen.changed.notify_all();
      });
  locd::dds::Reader<locd_msg_PoseEstimate> poses(
      participant, locd::topics::kPose, QosProfile::kPose, [&](const locd_msg_PoseEstimate& m) {
        const locd::PoseEstimate p = locd::dds::from_wire(m);
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.poses.push_back({p.header.stamp_ns, locd::Pose2::from_isometry(p.pose)});
        seen.changed.notify_all();
      });
  locd::dds::Reader<locd_msg_Diagnostics> diagnostics(
      participant, locd::topics::kDiagnostics, QosProfile::kSensor, [&](const locd_msg_Diagnostics& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        if (m.particles._length > 0) ++seen.diagnostics_with_particles;
        seen.diagnostics_plugin = locd::dds::to_string(m.plugin);
      }, 64);
  const auto deadline = std::chrono::steady_clock::now() + kTimeout;
  while (requests.matched() == 0 || odometry.matched() == 0 || images.matched() == 0 || statuses.matched() == 0) {
    ASSERT_TRUE(std::chrono::steady_clock::now() < deadline && locd.running()) << "locd did not come up:\n" << locd.output();
    std::this_thread::sleep_for(10ms);
  }

  // The world of the scenario, the shipped plugin config with the start pose added.
  const locd::Params scenario = locd::Params::load_file(locd::test::source_dir() + "/config/scenarios/ceiling_hall.yaml");
  const locd::Params cam = scenario.child("sensors").child("ceiling_camera");
  const simc::CeilingWorld world(simc::CeilingWorldConfig::from_params(cam.child("world")));
  const simc::CeilingCameraRenderer renderer(simc::CeilingCameraConfig::from_params(cam), world);
  simc::HallDrive drive(simc::DriveConfig{}, renderer, 8);
  const locd::Pose2 start = drive.truth().pose;
  std::string config = read(fs::path(locd::test::source_dir()) / "config/plugins/ceiling_pf.yaml");
  const std::string marker = "# initial_pose: [30.38, 27.2, 0.0]";
  config.replace(config.find(marker), marker.size(),
                 "initial_pose: [" + std::to_string(start.x) + ", " + std::to_string(start.y) + ", " +
                     std::to_string(start.theta) + "]");
  auto request = std::make_unique<locd_msg_SessionRequest>();
  std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
  locd::dds::copy_string(request->robot_id, "hall_bot");
  request->request_id = 1;
  request->action = locd_msg_SESSION_START;
  locd::dds::copy_string(request->plugin, "ceiling_pf");
  locd::dds::copy_string(request->config_yaml, config);
  requests.write(*request);
  {
    std::unique_lock<std::mutex> lock(seen.mutex);
    ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] { return seen.running; }))
        << "session not running: " << seen.message << "\n" << locd.output();
  }

  std::map<int64_t, locd::Pose2> truth;
  auto stream = [&](double until) {
    while (auto e = drive.next(until)) {
      if (const auto* o = std::get_if<locd::Odometry>(&e->measurement)) {
        locd::dds::write(odometry, "hall_bot", *o);
        truth[o->header.stamp_ns] = e->truth;
      } else if (const auto* img = std::get_if<locd::Image>(&e->measurement)) {
        locd::dds::write(images, "hall_bot", *img);
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
  locd::dds::write(images, "hall_bot", small);
  {
    std::unique_lock<std::mutex> lock(seen.mutex);
    ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] { return seen.rejected >= 1; })) << locd.output();
    EXPECT_NE(seen.last_error.find("640 x 480"), std::string::npos) << seen.last_error;
  }
  const size_t poses_before = [&] {
    std::lock_guard<std::mutex> lock(seen.mutex);
    return seen.poses.size();
  }();
  stream(25.0);
  const int64_t last_stamp = truth.rbegin()->first;
  std::unique_lock<std::mutex> lock(seen.mutex);
  ASSERT_TRUE(seen.changed.wait_for(lock, kTimeout, [&] {
    return !seen.poses.empty() && seen.poses.back().first == last_stamp;
  })) << "no pose for the last measurement; poses " << seen.poses.size() << "\n" << locd.output();
  EXPECT_GT(seen.poses.size(), poses_before) << "the session goes on after the bad frame";
  EXPECT_GT(seen.diagnostics_with_particles, 10u);
  EXPECT_EQ(seen.diagnostics_plugin, "ceiling_pf");
  double max_error = 0.0;
  for (const auto& [stamp, pose] : seen.poses) {
    const auto t = truth.find(stamp);
    if (t == truth.end()) continue;
    max_error = std::max(max_error, std::hypot(pose.x - t->second.x, pose.y - t->second.y));
  }
  EXPECT_LT(max_error, 0.25);
  EXPECT_LT(std::hypot(seen.poses.back().second.x - truth.rbegin()->second.x,
                       seen.poses.back().second.y - truth.rbegin()->second.y), 0.1);
  lock.unlock();
}

}  // namespace
