// The paper's motion model (eq. 1, 4-6): state x = [x, y, theta], control u = [V, gamma]
// (forward speed, heading change over dt), taken from two consecutive odometry poses.
#pragma once

#include <Eigen/Core>

#include "locd/feature_ekf/config.hpp"
#include "locd/sdk/geometry.hpp"

namespace locd::feature_ekf {

struct MotionControl {
  double speed = 0.0;  // V, m/s, negative when driving backwards
  double turn = 0.0;   // gamma, rad
  double dt = 0.0;     // s
};

class OdometryMotionModel {
 public:
  explicit OdometryMotionModel(MotionNoiseConfig noise = {}) : noise_(noise) {}

  // u from odometry poses at t0 and t0 + dt (dt > 0): V dt is the signed distance travelled,
  // gamma the heading change.
  static MotionControl control_from_odometry(const Pose2& previous, const Pose2& current, double dt);

  // Eq. 1.
  static Eigen::Vector3d predict(const Eigen::Vector3d& state, const MotionControl& u);
  // Eq. 6: df/dx and df/du.
  static Eigen::Matrix3d jacobian_state(const Eigen::Vector3d& state, const MotionControl& u);
  static Eigen::Matrix<double, 3, 2> jacobian_control(const Eigen::Vector3d& state, const MotionControl& u);
  // Eq. 6: Q = diag(sigma_v^2, sigma_gamma^2) from the noise model above.
  Eigen::Matrix2d control_noise(const MotionControl& u) const;

  const MotionNoiseConfig& noise() const { return noise_; }

 private:
  MotionNoiseConfig noise_;
};

}  // namespace locd::feature_ekf
