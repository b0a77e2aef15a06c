// TUM reference trajectories (issue 21): interpolation between poses, gaps and ends not bridged,
// every bad line named by file, line and field, and the APE / RPE of known errors.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "locd/sim/reference_trajectory.hpp"

namespace fs = std::filesystem;
using locd::sim::ReferenceError;
using locd::sim::ReferenceTrajectory;

namespace {

fs::path write(const std::string& name, const std::string& text) {
  const fs::path file = fs::temp_directory_path() / ("reference_trajectory_test_" + std::to_string(::getpid()) + name);
  std::ofstream(file) << text;
  return file;
}

Eigen::Isometry3d planar(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, 0);
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

double yaw_of(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

std::string error_of(const std::string& text) {
  const fs::path file = write("bad.tum", text);
  try {
    ReferenceTrajectory::read_tum(file.string());
  } catch (const ReferenceError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(ReferenceTrajectory, InterpolatesWithinAndNotBeyondOrAcrossGaps) {
  // yaw 0 at t = 10 s, 90 deg at 11 s (qz = qw = sqrt(0.5)), then a 5 s gap.
  const fs::path file = write("ok.tum",
                              "# t x y z qx qy qz qw\n\n10.0 0 0 0 0 0 0 1\n"
                              "10.999999999 2 4 0 0 0 0.7071067811865476 0.7071067811865476\n16.5 9 9 0 0 0 0 1\n");
  const ReferenceTrajectory r = ReferenceTrajectory::read_tum(file.string());
  EXPECT_EQ(r.size(), 3u);
  EXPECT_EQ(r.first_ns(), 10'000'000'000);
  EXPECT_EQ(r.last_ns(), 16'500'000'000);
  EXPECT_EQ(r.at(10'999'999'999)->translation().x(), 2.0);  // exact stamp, nanosecond precision kept
  const auto mid = r.at(10'500'000'000);
  ASSERT_TRUE(mid);
  EXPECT_NEAR(mid->translation().x(), 1.0, 1e-6);
  EXPECT_NEAR(mid->translation().y(), 2.0, 1e-6);
  EXPECT_NEAR(yaw_of(*mid), M_PI / 4, 1e-6);
  EXPECT_FALSE(r.at(9'999'999'999));   // before the first
  EXPECT_FALSE(r.at(16'500'000'001));  // after the last
  EXPECT_FALSE(r.at(13'000'000'000));  // in the 5.5 s gap
  fs::remove(file);
}

TEST(ReferenceTrajectory, BadLinesNameFileLineAndField) {
  EXPECT_NE(error_of("1 0 0 0 0 0 0 1\n2 0 0\n").find("line 2: field z is missing"), std::string::npos);
  EXPECT_NE(error_of("1 0 0 0 0 0 0 1 7\n").find("line 1: more than 8 fields"), std::string::npos);
  EXPECT_NE(error_of("1 0 zero 0 0 0 0 1\n").find("line 1: field y = 'zero' is not a finite number"), std::string::npos);
  EXPECT_NE(error_of("1 0 0 0 0 0 0 inf\n").find("field qw = 'inf' is not a finite number"), std::string::npos);
  EXPECT_NE(error_of("1 0 0 0 0 0 0 0\n").find("line 1: fields qx qy qz qw are a zero quaternion"), std::string::npos);
  EXPECT_NE(error_of("2 0 0 0 0 0 0 1\n# c\n2 0 0 0 0 0 0 1\n").find("line 3: field t goes backwards or repeats"),
            std::string::npos);
  EXPECT_NE(error_of("-1 0 0 0 0 0 0 1\n").find("line 1: field t"), std::string::npos);
  EXPECT_NE(error_of("# only a comment\n").find("no pose"), std::string::npos);
  try {
    ReferenceTrajectory::read_tum("/nonexistent/ref.tum");
    FAIL() << "no error";
  } catch (const ReferenceError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/ref.tum: cannot be opened"), std::string::npos);
  }
}

TEST(ReferenceTrajectory, ApeAndRpeOfKnownErrors) {
  // Reference: x = t along a straight line, 1 pose a second from 0 to 10 s.
  std::string text;
  for (int t = 1; t <= 10; ++t) text += std::to_string(t) + " " + std::to_string(t) + " 0 0 0 0 0 1\n";
  const fs::path file = write("line.tum", text);
  const ReferenceTrajectory r = ReferenceTrajectory::read_tum(file.string());
  // Estimates 0.1 m to the side everywhere, one 1 m off at t = 5, one outside the reference.
  std::map<int64_t, Eigen::Isometry3d> poses;
  for (int t = 1; t <= 10; ++t) poses[int64_t{t} * 1'000'000'000] = planar(t, t == 5 ? 1.0 : 0.1, 0.0);
  poses[20'000'000'000] = planar(20, 0, 0);
  const auto e = locd::sim::absolute_pose_error(poses, r);
  EXPECT_EQ(e.poses, 10u);
  EXPECT_EQ(e.not_covered, 1u);
  EXPECT_NEAR(e.rmse_m, std::sqrt((9 * 0.01 + 1.0) / 10), 1e-9);
  EXPECT_NEAR(e.mean_m, (9 * 0.1 + 1.0) / 10, 1e-9);
  EXPECT_NEAR(e.median_m, 0.1, 1e-9);
  EXPECT_NEAR(e.max_m, 1.0, 1e-9);
  EXPECT_NEAR(e.share_over_half_metre, 0.1, 1e-12);
  EXPECT_NEAR(e.heading_max_deg, 0.0, 1e-9);
  // RPE: only the steps into and out of t = 5 are wrong, by 0.9 m each, of 9 pairs.
  EXPECT_EQ(e.rpe_pairs, 9u);
  EXPECT_NEAR(e.rpe_max_m, 0.9, 1e-9);
  EXPECT_NEAR(e.rpe_rmse_m, std::sqrt(2 * 0.81 / 9), 1e-9);
  EXPECT_NEAR(e.rpe_median_m, 0.0, 1e-9);
  fs::remove(file);
}
