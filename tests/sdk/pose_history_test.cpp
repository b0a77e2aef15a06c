// The odometry history (the map -> odom transform, grid_mcl's odometry at a scan's stamp):
// interpolation against the formula.
#include <gtest/gtest.h>

#include "locd/sdk/pose_history.hpp"

#include <random>

#include "locd/sdk/geometry.hpp"

using locd::PoseHistory;

namespace {

Eigen::Isometry3d planar(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, 0);
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

}  // namespace

TEST(PoseHistory, InterpolatesBetweenTheSamplesAround) {
  PoseHistory h;
  h.add(1000, planar(0, 0, 0.0));
  h.add(2000, planar(1, 2, 0.4));
  h.add(4000, planar(3, 2, 0.8));
  // A quarter of the way from 2000 to 4000: translation and yaw a quarter of the way (planar
  // slerp is linear in the angle).
  const auto p = h.at(2500);
  ASSERT_TRUE(p.has_value());
  EXPECT_TRUE(p->translation().isApprox(Eigen::Vector3d(1.5, 2, 0), 1e-12));
  EXPECT_NEAR(Eigen::AngleAxisd(p->linear()).angle(), 0.5, 1e-12);
  EXPECT_TRUE(h.at(2000)->isApprox(planar(1, 2, 0.4)));
  EXPECT_FALSE(h.at(999).has_value());                        // older than every sample
  EXPECT_TRUE(h.at(9000)->isApprox(planar(3, 2, 0.8)));      // newer: the newest sample
}

TEST(PoseHistory, BoundedAndInOrder) {
  PoseHistory h(3);
  for (int i = 0; i < 10; ++i) h.add(i * 100, planar(i, 0, 0));
  h.add(50, planar(-1, 0, 0));  // older than the newest: ignored
  EXPECT_EQ(h.size(), 3u);
  EXPECT_FALSE(h.at(600).has_value());
  EXPECT_TRUE(h.at(750)->translation().isApprox(Eigen::Vector3d(7.5, 0, 0)));
}

// grid_mcl's odometry at a scan's stamp: against the direct planar formula, x and y linear in
// the stamp and the yaw along the shorter arc, over random samples (headings crossing +-pi).
TEST(PoseHistory, PlanarOdometryAtAStampMatchesTheDirectFormula) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> position(-50.0, 50.0), heading(-M_PI, M_PI), unit(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const double x0 = position(rng), y0 = position(rng), a0 = heading(rng);
    const double x1 = position(rng), y1 = position(rng), a1 = heading(rng);
    const int64_t t0 = 1'000'000'000 + trial * 1'000'000'000LL, t1 = t0 + 1 + static_cast<int64_t>(unit(rng) * 5e8);
    PoseHistory h;
    h.add(t0, planar(x0, y0, a0));
    h.add(t1, planar(x1, y1, a1));
    const int64_t t = t0 + static_cast<int64_t>(unit(rng) * static_cast<double>(t1 - t0));
    const double s = static_cast<double>(t - t0) / static_cast<double>(t1 - t0);
    const locd::Pose2 got = locd::Pose2::from_isometry(*h.at(t));
    EXPECT_NEAR(got.x, x0 + s * (x1 - x0), 1e-9);
    EXPECT_NEAR(got.y, y0 + s * (y1 - y0), 1e-9);
    EXPECT_NEAR(locd::normalize_angle(got.theta - (a0 + s * locd::normalize_angle(a1 - a0))), 0.0, 1e-9) << trial;
  }
  PoseHistory wrap;  // 170 deg -> -170 deg crosses 180 deg, not 0
  wrap.add(0, planar(0, 0, 170.0 * M_PI / 180.0));
  wrap.add(100, planar(0, 0, -170.0 * M_PI / 180.0));
  EXPECT_NEAR(std::abs(locd::Pose2::from_isometry(*wrap.at(50)).theta), M_PI, 1e-9);
}
