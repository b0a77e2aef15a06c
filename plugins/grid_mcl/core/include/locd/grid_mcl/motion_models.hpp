// AMCL's odometry motion models (robot_model_type), sampling each particle's motion from the
// odometry increment between two odometry poses (Probabilistic Robotics, Table 5.6):
//
//   differential      delta_rot1 = atan2(dy, dx) - theta, delta_trans, delta_rot2 = dtheta - delta_rot1;
//                     each perturbed by N(0, s^2) with
//                       s_rot1^2  = alpha1 rot1^2 + alpha2 trans^2
//                       s_trans^2 = alpha3 trans^2 + alpha4 (rot1^2 + rot2^2)
//                       s_rot2^2  = alpha1 rot2^2 + alpha2 trans^2
//                     where a rotation counts as its smallest angle to forward or backward (AMCL's
//                     "corrected" model: driving backwards is not a half turn), and rot1 = 0 below
//                     1 cm of travel
//   omnidirectional   translation along its bearing, a strafe across it and the rotation:
//                       s_trans^2  = alpha3 trans^2 + alpha1 rot^2
//                       s_rot^2    = alpha4 trans^2 + alpha2 rot^2
//                       s_strafe^2 = alpha1 rot^2 + alpha5 trans^2
// (the alphas are variances per squared motion, as in AMCL). Deviates come from the sdk's
// ziggurat sampler.
#pragma once

#include <random>
#include <vector>

#include "locd/grid_mcl/config.hpp"
#include "locd/sdk/gaussian.hpp"
#include "locd/sdk/particle_filter.hpp"

namespace locd::grid_mcl {

class MotionModel {
 public:
  MotionModel(MotionModelType type, const MotionNoise& noise);

  // Moves every particle by the odometry increment from `before` to `after` (odom frame).
  void sample(std::vector<PoseParticle>& particles, const Pose2& before, const Pose2& after, std::mt19937_64& rng) const;
  // The standard deviations the increment gets: (rot1, trans, rot2) or (trans, rot, strafe).
  Eigen::Vector3d stddev(const Pose2& before, const Pose2& after) const;

  MotionModelType type() const { return type_; }

 private:
  MotionModelType type_;
  MotionNoise noise_;
  ZigguratNormal normal_;
};

}  // namespace locd::grid_mcl
