#include "locd/sdk/initial_pose.hpp"

#include <Eigen/Cholesky>

#include "locd/sdk/errors.hpp"

namespace locd {

PlanarInitialPose planar_initial_pose(const PoseEstimate& pose, const std::string& plugin) {
  PlanarInitialPose out;
  out.mean = Pose2::from_isometry(pose.pose);
  if (!std::isfinite(out.mean.x) || !std::isfinite(out.mean.y) || !std::isfinite(out.mean.theta)) {
    throw InputError(plugin + ": initial pose: position and yaw must be finite");
  }
  const Eigen::Matrix3d planar = planar_covariance(pose.covariance);
  out.covariance_finite = planar.allFinite();
  if (!out.covariance_finite) return out;
  out.covariance = 0.5 * (planar + planar.transpose());
  out.covariance_positive_definite = Eigen::LLT<Eigen::Matrix3d>(out.covariance).info() == Eigen::Success;
  return out;
}

}  // namespace locd
