#include "locd/feature_ekf/odometry_motion_model.hpp"

#include <cmath>

namespace locd::feature_ekf {

MotionControl OdometryMotionModel::control_from_odometry(const Pose2& previous, const Pose2& current,
                                                        double dt) {
  const Pose2 step = previous.inverse() * current;
  const double distance = std::hypot(step.x, step.y);
  MotionControl u;
  u.dt = dt;
  u.turn = step.theta;
  u.speed = (step.x < 0.0 ? -distance : distance) / dt;
  return u;
}

Eigen::Vector3d OdometryMotionModel::predict(const Eigen::Vector3d& state, const MotionControl& u) {
  const double heading = state.z() + u.turn;
  return {state.x() + u.dt * u.speed * std::cos(heading), state.y() + u.dt * u.speed * std::sin(heading),
          normalize_angle(heading)};
}

Eigen::Matrix3d OdometryMotionModel::jacobian_state(const Eigen::Vector3d& state, const MotionControl& u) {
  const double heading = state.z() + u.turn;
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  F(0, 2) = -u.dt * u.speed * std::sin(heading);
  F(1, 2) = u.dt * u.speed * std::cos(heading);
  return F;
}

Eigen::Matrix<double, 3, 2> OdometryMotionModel::jacobian_control(const Eigen::Vector3d& state,
                                                                  const MotionControl& u) {
  const double heading = state.z() + u.turn;
  const double c = std::cos(heading), s = std::sin(heading);
  Eigen::Matrix<double, 3, 2> G;
  G << u.dt * c, -u.dt * u.speed * s,  //
      u.dt * s, u.dt * u.speed * c,    //
      0.0, 1.0;
  return G;
}

Eigen::Matrix2d OdometryMotionModel::control_noise(const MotionControl& u) const {
  const double sigma_speed = noise_.speed_stddev_per_speed * std::abs(u.speed) + noise_.speed_stddev_floor;
  const double sigma_turn = noise_.turn_stddev_per_turn * std::abs(u.turn) +
                            noise_.turn_stddev_per_distance * std::abs(u.speed * u.dt) +
                            noise_.turn_stddev_floor;
  return Eigen::Vector2d(sigma_speed * sigma_speed, sigma_turn * sigma_turn).asDiagonal();
}

}  // namespace locd::feature_ekf
