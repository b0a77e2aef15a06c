// Where sessions resume: the odometry carried to a stamp by its velocity (against the motion it
// integrates), map_from_odom, the resumed pose, and the state file's round trip and refusals.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "locd/server/resume.hpp"

namespace {

using namespace locd;
using namespace locd::server;
namespace fs = std::filesystem;

Odometry odometry(int64_t stamp, double x, double y, double yaw, double v = 0.0, double w = 0.0) {
  Odometry o;
  o.header.stamp_ns = stamp;
  o.pose = Eigen::Translation3d(x, y, 0.0) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
  o.linear_velocity = {v, 0.0, 0.0};
  o.angular_velocity = {0.0, 0.0, w};
  return o;
}

TEST(Resume, OdometryIsCarriedOnByItsVelocity) {
  // Straight at 1 m/s, heading 90 degrees: 0.2 s later the robot is 0.2 m further along y.
  const Odometry o = odometry(1'000'000'000, 1.0, 2.0, M_PI / 2, 1.0, 0.0);
  const auto at = odometry_at(o, 1'200'000'000);
  ASSERT_TRUE(at);
  EXPECT_NEAR(at->translation().x(), 1.0, 1e-12);
  EXPECT_NEAR(at->translation().y(), 2.2, 1e-12);
  // Turning on the spot at 0.5 rad/s for 0.4 s.
  const auto turned = odometry_at(odometry(0, 0, 0, 0.1, 0.0, 0.5), 400'000'000);
  ASSERT_TRUE(turned);
  EXPECT_NEAR(Eigen::AngleAxisd(turned->linear()).angle(), 0.3, 1e-12);
  // Backwards too (a scan stamped a little before the newest odometry): 0.1 s before, 0.1 m back.
  const auto before = odometry_at(o, 900'000'000);
  ASSERT_TRUE(before);
  EXPECT_NEAR(before->translation().y(), 1.9, 1e-12);
  // Not across a gap longer than a second, either way.
  EXPECT_FALSE(odometry_at(o, 1'000'000'000 + kMaxOdometryExtrapolationNs + 1));
  EXPECT_FALSE(odometry_at(o, 1'000'000'000 - kMaxOdometryExtrapolationNs - 1));
}

TEST(Resume, ThePoseFollowsTheOdometryOverTheGap) {
  ResumeState state;
  state.estimate.header.stamp_ns = 1000;
  state.estimate.pose = Eigen::Translation3d(10.0, 5.0, 0.0) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ());
  state.estimate.covariance = Matrix6d::Identity() * 0.01;
  const Odometry then = odometry(1000, 2.0, 1.0, 0.2);
  state.map_from_odom = map_from_odom(state.estimate, then);
  ASSERT_TRUE(state.map_from_odom);
  // The robot drove on: the resumed pose is the estimate moved by the odometry's own motion.
  const Odometry now = odometry(5000, 3.0, 1.5, 0.4);
  const PoseEstimate resumed = resume_pose(state, &now);
  const Eigen::Isometry3d expected = state.estimate.pose * (then.pose.inverse() * now.pose);
  EXPECT_TRUE(resumed.pose.isApprox(expected, 1e-12));
  EXPECT_EQ(resumed.header.stamp_ns, 5000);
  EXPECT_EQ(resumed.covariance, state.estimate.covariance);
  // An odometry older than the estimate (a robot whose clock began again) is not trusted.
  const Odometry restarted = odometry(10, 0.0, 0.0, 0.0);
  EXPECT_TRUE(resume_pose(state, &restarted).pose.isApprox(state.estimate.pose, 0.0));
  EXPECT_TRUE(resume_pose(state, nullptr).pose.isApprox(state.estimate.pose, 0.0));
}

class StateFileTest : public ::testing::Test {
 protected:
  StateFileTest() : dir_(fs::temp_directory_path() / ("locd_state_" + std::to_string(::getpid()))) {
    fs::create_directories(dir_);
  }
  ~StateFileTest() override { fs::remove_all(dir_); }
  fs::path dir_;
  Logger logger_{LogLevel::kError};
};

TEST_F(StateFileTest, StatesRoundTrip) {
  StateFile file(dir_);
  ResumeState a;
  a.plugin = "feature_ekf";
  a.request_id = 77;
  a.estimate.header.stamp_ns = 123456789;
  a.estimate.pose = Eigen::Translation3d(1.5, -2.0, 0.0) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ());
  a.estimate.covariance = Matrix6d::Identity() * 0.02;
  a.estimate.covariance(0, 1) = a.estimate.covariance(1, 0) = 0.005;
  a.map_from_odom = Eigen::Isometry3d(Eigen::Translation3d(0.1, 0.2, 0.0));
  a.claim_strength = 123456789;
  ResumeState b;
  b.plugin = "faulty";
  b.request_id = 3;
  b.failed = true;
  file.write(StateFile::encode({{"robot_a", a}, {"robot.b", b}}));
  const auto loaded = file.load(logger_);
  ASSERT_EQ(loaded.size(), 2u);
  const ResumeState& la = loaded.at("robot_a");
  EXPECT_EQ(la.plugin, "feature_ekf");
  EXPECT_EQ(la.request_id, 77u);
  EXPECT_EQ(la.estimate.header.stamp_ns, 123456789);
  EXPECT_TRUE(la.estimate.pose.isApprox(a.estimate.pose, 1e-12));
  EXPECT_TRUE(la.estimate.covariance.isApprox(a.estimate.covariance, 1e-15));
  ASSERT_TRUE(la.map_from_odom);
  EXPECT_TRUE(la.map_from_odom->isApprox(*a.map_from_odom, 1e-12));
  EXPECT_EQ(la.claim_strength, 123456789);
  EXPECT_TRUE(loaded.at("robot.b").failed);
  EXPECT_FALSE(loaded.at("robot.b").map_from_odom);
  EXPECT_EQ(loaded.at("robot.b").claim_strength, 0);
}

TEST_F(StateFileTest, AMissingOrMalformedFileIsEmptyAndBadEntriesAreSkipped) {
  StateFile file(dir_);
  EXPECT_TRUE(file.load(logger_).empty());
  std::ofstream(file.file()) << "{not json";
  EXPECT_TRUE(file.load(logger_).empty());
  std::ofstream(file.file()) << R"({"version": 1, "robots": {
    "good": {"plugin": "p", "request_id": 1, "stamp_ns": 5, "pose": [0,0,0,0,0,0,1],
             "covariance": [1,0,0,0,0,0, 0,1,0,0,0,0, 0,0,1,0,0,0, 0,0,0,1,0,0, 0,0,0,0,1,0, 0,0,0,0,0,1]},
    "bad\nid": {"plugin": "p", "request_id": 1, "stamp_ns": 5, "pose": [0,0,0,0,0,0,1], "covariance": []},
    "negative": {"plugin": "p", "request_id": 1, "stamp_ns": 5, "pose": [0,0,0,0,0,0,1],
             "covariance": [-1,0,0,0,0,0, 0,1,0,0,0,0, 0,0,1,0,0,0, 0,0,0,1,0,0, 0,0,0,0,1,0, 0,0,0,0,0,1]},
    "short": {"plugin": "p", "request_id": 1, "stamp_ns": 5, "pose": [0,0,0], "covariance": []}}})";
  const auto loaded = file.load(logger_);
  ASSERT_EQ(loaded.size(), 1u);
  EXPECT_TRUE(loaded.count("good"));
}

TEST_F(StateFileTest, AnOversizedFileIsIgnored) {
  StateFile file(dir_);
  std::ofstream out(file.file());
  out << R"({"version": 1, "robots": {}, "padding": ")";
  out << std::string(StateFile::kMaxStateFileBytes, 'x') << "\"}";
  out.close();
  EXPECT_TRUE(file.load(logger_).empty());
}

TEST(StateFile, ADisabledFileNeitherLoadsNorWrites) {
  Logger logger(LogLevel::kError);
  StateFile none;
  EXPECT_FALSE(none.enabled());
  EXPECT_TRUE(none.load(logger).empty());
  none.write("{}");
}

}  // namespace
