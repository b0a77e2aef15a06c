#include "locd/sdk/geometry.hpp"

namespace locd {

Pose2 Pose2::operator*(const Pose2& o) const {
  const double c = std::cos(theta), s = std::sin(theta);
  return {x + c * o.x - s * o.y, y + s * o.x + c * o.y, normalize_angle(theta + o.theta)};
}

Pose2 Pose2::inverse() const {
  const double c = std::cos(theta), s = std::sin(theta);
  return {-c * x - s * y, s * x - c * y, normalize_angle(-theta)};
}

Eigen::Vector2d Pose2::transform(const Eigen::Vector2d& p) const {
  const double c = std::cos(theta), s = std::sin(theta);
  return {x + c * p.x() - s * p.y(), y + s * p.x() + c * p.y()};
}

Eigen::Isometry3d Pose2::to_isometry() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

Pose2 Pose2::from_isometry(const Eigen::Isometry3d& T) {
  return {T.translation().x(), T.translation().y(), yaw_of(T.linear())};
}

double yaw_of(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

Eigen::Vector3d roll_pitch_yaw(const Eigen::Matrix3d& R) {
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  const double pitch = std::atan2(-R(2, 0), std::hypot(R(2, 1), R(2, 2)));
  const double roll = std::atan2(R(2, 1), R(2, 2));
  return {roll, pitch, yaw};
}

Eigen::Quaterniond quaternion_from_rpy(double roll, double pitch, double yaw) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
}

Eigen::Isometry3d isometry_from_xyz_rpy(double x, double y, double z, double roll, double pitch,
                                        double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = quaternion_from_rpy(roll, pitch, yaw).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

}  // namespace locd
