// The odometry history behind the map -> odom transform: interpolation against the formula.
#include <gtest/gtest.h>

#include "locd/server/pose_history.hpp"

using locd::server::PoseHistory;

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
