// A pose a client sent to start from (locctl initial-pose, a ROS 2 robot's /initialpose), on the
// plane: checked here once for the plugins that localize in (x, y, yaw). What a plugin does with
// a covariance it cannot use (its configured default, or an error) stays its own choice.
#pragma once

#include <Eigen/Core>
#include <string>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/types.hpp"

namespace locd {

struct PlanarInitialPose {
  Pose2 mean;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // the (x, y, yaw) block, symmetrised
  bool covariance_finite = false;
  bool covariance_positive_definite = false;  // finite, and a filter can draw from it
};

// InputError "<plugin>: initial pose: position and yaw must be finite" unless they are.
PlanarInitialPose planar_initial_pose(const PoseEstimate& pose, const std::string& plugin);

}  // namespace locd
