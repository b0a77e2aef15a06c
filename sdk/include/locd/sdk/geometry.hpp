// SE(2) and SE(3) helpers on Eigen. Angles in radians, yaw counter-clockwise from x, z up.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace locd {

// Wraps an angle to [-pi, pi).
inline double normalize_angle(double a) {
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a < 0) a += 2.0 * M_PI;
  return a - M_PI;
}

// A planar pose: position (x, y) and heading theta.
struct Pose2 {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;

  Pose2() = default;
  Pose2(double x_, double y_, double theta_) : x(x_), y(y_), theta(theta_) {}
  Eigen::Vector3d vector() const { return {x, y, theta}; }
  static Pose2 from_vector(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

  // this ⊕ other: other expressed in this pose's frame, composed.
  Pose2 operator*(const Pose2& other) const;
  Pose2 inverse() const;
  Eigen::Vector2d transform(const Eigen::Vector2d& p) const;  // point in frame -> world

  // Embeds in 3D (z = 0, roll = pitch = 0) and back (drops z, roll, pitch).
  Eigen::Isometry3d to_isometry() const;
  static Pose2 from_isometry(const Eigen::Isometry3d& T);
};

// Yaw of a rotation (z-y-x Euler), robust for any pitch away from +-90 deg.
double yaw_of(const Eigen::Matrix3d& R);
// Roll, pitch, yaw (z-y-x) of a rotation.
Eigen::Vector3d roll_pitch_yaw(const Eigen::Matrix3d& R);
Eigen::Quaterniond quaternion_from_rpy(double roll, double pitch, double yaw);
Eigen::Isometry3d isometry_from_xyz_rpy(double x, double y, double z, double roll, double pitch,
                                        double yaw);

}  // namespace locd
