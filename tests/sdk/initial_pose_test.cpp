// The initial-pose check the planar plugins share (grid_mcl, ceiling_pf, feature_ekf,
// emoi_markov): a mean that is not finite is refused with the plugin named; the covariance's
// planar block comes back symmetrised, with whether it is finite and positive definite.
#include <gtest/gtest.h>

#include "locd/sdk/errors.hpp"
#include "locd/sdk/initial_pose.hpp"

#include <limits>

namespace {

using namespace locd;

PoseEstimate at(double x, double y, double yaw) {
  PoseEstimate p;
  p.pose = Eigen::Isometry3d::Identity();
  p.pose.translation() = Eigen::Vector3d(x, y, 0.0);
  p.pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  p.covariance.setZero();
  return p;
}

TEST(InitialPose, MeanAndPlanarCovarianceFromThePose) {
  PoseEstimate p = at(2.0, -1.0, 0.5);
  Eigen::Matrix3d planar;
  planar << 0.04, 0.01, 0.0, 0.01, 0.09, 0.002, 0.0, 0.002, 0.01;
  p.covariance = pose_covariance(planar);
  p.covariance(0, 1) = 0.03;  // not symmetric: the mean of the two halves
  p.covariance(2, 2) = std::numeric_limits<double>::infinity();  // z is not the plane's
  const PlanarInitialPose start = planar_initial_pose(p, "plugin");
  EXPECT_NEAR(start.mean.x, 2.0, 1e-12);
  EXPECT_NEAR(start.mean.y, -1.0, 1e-12);
  EXPECT_NEAR(start.mean.theta, 0.5, 1e-12);
  EXPECT_TRUE(start.covariance_finite);
  EXPECT_TRUE(start.covariance_positive_definite);
  EXPECT_NEAR(start.covariance(0, 1), 0.02, 1e-12);
  EXPECT_NEAR(start.covariance(1, 0), 0.02, 1e-12);
  EXPECT_NEAR(start.covariance(2, 1), 0.002, 1e-12);
}

TEST(InitialPose, ACovarianceAFilterCannotDrawFromIsSaidSo) {
  PoseEstimate p = at(0.0, 0.0, 0.0);  // zero covariance: semi-definite only
  PlanarInitialPose start = planar_initial_pose(p, "plugin");
  EXPECT_TRUE(start.covariance_finite);
  EXPECT_FALSE(start.covariance_positive_definite);
  p.covariance(0, 0) = -1.0;
  p.covariance(1, 1) = p.covariance(5, 5) = 1.0;
  EXPECT_FALSE(planar_initial_pose(p, "plugin").covariance_positive_definite);
  p.covariance(5, 5) = std::numeric_limits<double>::quiet_NaN();
  start = planar_initial_pose(p, "plugin");
  EXPECT_FALSE(start.covariance_finite);
  EXPECT_FALSE(start.covariance_positive_definite);
}

TEST(InitialPose, AMeanThatIsNotFiniteIsRefusedNamingThePlugin) {
  PoseEstimate p = at(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0);
  try {
    planar_initial_pose(p, "grid_mcl");
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "grid_mcl: initial pose: position and yaw must be finite");
  }
  p = at(1.0, std::numeric_limits<double>::infinity(), 0.0);
  EXPECT_THROW(planar_initial_pose(p, "ceiling_pf"), InputError);
}

}  // namespace
