#include "locd/feature_ekf/feature_measurement_model.hpp"

#include <cmath>

#include "locd/sdk/geometry.hpp"

namespace locd::feature_ekf {

Measurement2 FeatureMeasurementModel::predict_line(double rho, double alpha, const Eigen::Vector3d& pose,
                                                   MeasurementJacobian* H) {
  const double c = std::cos(alpha), s = std::sin(alpha);
  double r = rho - pose.x() * c - pose.y() * s;
  double phi = alpha - pose.z();
  double sign = 1.0;
  if (r < 0.0) {  // the robot is on the far side of the line from the map origin
    r = -r;
    phi += M_PI;
    sign = -1.0;
  }
  if (H) {
    *H << -sign * c, -sign * s, 0.0,  //
        0.0, 0.0, -1.0;
  }
  return {r, normalize_angle(phi)};
}

Measurement2 FeatureMeasurementModel::predict_point(const Eigen::Vector2d& point, const Eigen::Vector3d& pose,
                                                    MeasurementJacobian* H) {
  const double dx = point.x() - pose.x(), dy = point.y() - pose.y();
  const double d2 = dx * dx + dy * dy;
  const double d = std::sqrt(d2);
  if (H) {
    *H << -dx / d, -dy / d, 0.0,  //
        dy / d2, -dx / d2, -1.0;
  }
  return {d, normalize_angle(std::atan2(dy, dx) - pose.z())};
}

Measurement2 FeatureMeasurementModel::innovation(const Measurement2& measured, const Measurement2& predicted) {
  return {measured.x() - predicted.x(), normalize_angle(measured.y() - predicted.y())};
}

}  // namespace locd::feature_ekf
