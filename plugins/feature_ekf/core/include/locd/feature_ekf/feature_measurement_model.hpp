// Measurement models of eq. 3 / 8 and their Jacobians (eq. 11), all in the robot frame
// (base_link) for a robot pose x = [x, y, theta] in the map frame.
//   h_L: a map line in normal form (rho, alpha), rho = x cos(alpha) + y sin(alpha), seen from the
//        robot as (r, phi): distance to the line and direction of its normal, r >= 0.
//   h_C, h_E: a map point (corner or edge) seen as (range, bearing).
#pragma once

#include <Eigen/Core>

namespace locd::feature_ekf {

using Measurement2 = Eigen::Vector2d;
using MeasurementJacobian = Eigen::Matrix<double, 2, 3>;

struct FeatureMeasurementModel {
  // Eq. 3 (h_L) and eq. 11 (first Jacobian). H may be null.
  static Measurement2 predict_line(double rho, double alpha, const Eigen::Vector3d& pose,
                                   MeasurementJacobian* H = nullptr);
  // Eq. 3 (h_C, h_E) and eq. 11 (second Jacobian). H may be null.
  static Measurement2 predict_point(const Eigen::Vector2d& point, const Eigen::Vector3d& pose,
                                    MeasurementJacobian* H = nullptr);
  // Eq. 9: z - h, with the angle component wrapped to [-pi, pi).
  static Measurement2 innovation(const Measurement2& measured, const Measurement2& predicted);
};

}  // namespace locd::feature_ekf
