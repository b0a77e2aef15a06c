// Sensor frames from /tf_static and /tf (TransformBuffer): lookups compose the chain to the common
// ancestor as tf2 does, interpolate dynamic links, never extrapolate, and say what is missing.
#include <gtest/gtest.h>

#include <cmath>

#include "error_of.hpp"
#include "locd/server/transform_buffer.hpp"

using namespace locd;
using locd::server::TransformBuffer;
using locd::test::error_of;

namespace {

Eigen::Isometry3d pose(double x, double y, double z, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, z);
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

dds::ros2::StampedTransform link(const std::string& parent, const std::string& child, const Eigen::Isometry3d& T,
                                 int64_t stamp_ns = 0) {
  return {stamp_ns, parent, child, T};
}

}  // namespace

TEST(TransformBuffer, ComposesStaticChainsBothWays) {
  // robot_state_publisher's tree: base_footprint -> base_link -> laser_mount -> laser.
  TransformBuffer tf;
  const Eigen::Isometry3d footprint_link = pose(0, 0, 0.1, 0), link_mount = pose(0.2, 0.05, 0.3, 0.4),
                          mount_laser = pose(0.01, 0, 0.02, M_PI);
  tf.add(link("base_footprint", "base_link", footprint_link), true);
  tf.add(link("base_link", "laser_mount", link_mount), true);
  tf.add(link("laser_mount", "laser", mount_laser), true);
  const Eigen::Isometry3d expected = footprint_link * link_mount * mount_laser;
  EXPECT_TRUE(tf.pose_in("base_footprint", "laser", 123).isApprox(expected, 1e-12));
  EXPECT_TRUE(tf.pose_in("laser", "base_footprint", 0).isApprox(expected.inverse(), 1e-12));
  EXPECT_TRUE(tf.pose_in("base_link", "base_link", 5).isApprox(Eigen::Isometry3d::Identity()));
  // Siblings meet at their common ancestor, not at the root.
  tf.add(link("base_link", "camera", pose(0.3, -0.1, 0.5, -0.2)), true);
  EXPECT_TRUE(tf.pose_in("camera", "laser", 0).isApprox(pose(0.3, -0.1, 0.5, -0.2).inverse() * link_mount * mount_laser,
                                                         1e-12));
  // A later static transform for the same child replaces the earlier one (as tf2's).
  tf.add(link("base_link", "laser_mount", pose(0, 0, 0, 0)), true);
  EXPECT_TRUE(tf.pose_in("base_link", "laser", 0).isApprox(mount_laser, 1e-12));
}

TEST(TransformBuffer, DynamicLinksInterpolateAndNeverExtrapolate) {
  // A tilting or panning laser on /tf: samples at 1 s and 2 s.
  TransformBuffer tf;
  tf.add(link("base_link", "laser", pose(0, 0, 0, 0.0), 1'000'000'000), false);
  tf.add(link("base_link", "laser", pose(1, 0, 0, 0.4), 2'000'000'000), false);
  const Eigen::Isometry3d half = tf.pose_in("base_link", "laser", 1'500'000'000);
  EXPECT_TRUE(half.translation().isApprox(Eigen::Vector3d(0.5, 0, 0), 1e-12));
  EXPECT_NEAR(Eigen::AngleAxisd(half.linear()).angle(), 0.2, 1e-12);
  EXPECT_TRUE(tf.pose_in("base_link", "laser", 2'000'000'000).isApprox(pose(1, 0, 0, 0.4), 1e-12));
  const std::string later = error_of<InputError>([&] { tf.pose_in("base_link", "laser", 2'100'000'000); });
  EXPECT_NE(later.find("transform 'base_link' -> 'laser' on tf has no sample around the stamp 2.100 s (it holds "
                       "1.000 s to 2.000 s); tf2 does not extrapolate"),
            std::string::npos) << later;
  EXPECT_NE(error_of<InputError>([&] { tf.pose_in("base_link", "laser", 900'000'000); }).find("no sample around"),
            std::string::npos);
  EXPECT_NE(error_of<InputError>([&] { tf.add(link("base_link", "laser", pose(0, 0, 0, 0)), false); }).find("zero stamp"),
            std::string::npos);
}

TEST(TransformBuffer, SaysWhatIsMissing) {
  TransformBuffer tf;
  const std::string none = error_of<InputError>([&] { tf.pose_in("base_link", "laser", 0); });
  EXPECT_NE(none.find("frame 'laser' is on neither /tf_static nor /tf (and ros2.sensor_frames is not given)"),
            std::string::npos) << none;
  tf.add(link("base_link", "laser", pose(0, 0, 0, 0)), true);
  tf.add(link("odom", "base_footprint", pose(0, 0, 0, 0)), true);
  const std::string apart = error_of<InputError>([&] { tf.pose_in("base_footprint", "laser", 0); });
  EXPECT_NE(apart.find("frames 'laser' and 'base_footprint' are not connected on /tf_static and /tf ('laser' leads up "
                       "to 'base_link', 'base_footprint' to 'odom')"),
            std::string::npos) << apart;
  // A loop in what a robot sent is refused, not followed forever.
  tf.add(link("laser", "base_link", pose(0, 0, 0, 0)), true);
  EXPECT_NE(error_of<InputError>([&] { tf.pose_in("odom", "laser", 0); }).find("(a loop?)"), std::string::npos);
}

TEST(TransformBuffer, BoundedInFrames) {
  TransformBuffer tf;
  for (size_t i = 0; i < TransformBuffer::kMaxFrames + 10; ++i) {
    tf.add(link("base_link", "f" + std::to_string(i), pose(static_cast<double>(i), 0, 0, 0)), true);
  }
  EXPECT_NO_THROW(tf.pose_in("base_link", "f0", 0));
  EXPECT_THROW(tf.pose_in("base_link", "f" + std::to_string(TransformBuffer::kMaxFrames + 5), 0), InputError);
}
