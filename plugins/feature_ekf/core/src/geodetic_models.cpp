#include "locd/feature_ekf/geodetic_models.hpp"

#include <cmath>

namespace locd::feature_ekf {

EarthRadii earth_radii(double latitude_rad) {
  const double s = std::sin(latitude_rad);
  const double w = 1.0 - wgs84::kEccentricity2 * s * s;
  return {wgs84::kSemiMajorAxis * (1.0 - wgs84::kEccentricity2) / std::pow(w, 1.5),
          wgs84::kSemiMajorAxis / std::sqrt(w)};
}

OperatingArea OperatingArea::centred_at(double latitude_rad, double longitude_rad, double altitude_m) {
  OperatingArea a;
  a.latitude = latitude_rad;
  a.longitude = longitude_rad;
  a.altitude = altitude_m;
  a.radii = earth_radii(latitude_rad);
  return a;
}

Eigen::Vector2d OperatingArea::to_enu(double latitude_rad, double longitude_rad) const {
  return {(longitude_rad - longitude) * (radii.transverse + altitude) * std::cos(latitude),
          (latitude_rad - latitude) * (radii.meridian + altitude)};
}

Eigen::Vector2d OperatingArea::to_geodetic(const Eigen::Vector2d& enu) const {
  return {latitude + enu.y() / (radii.meridian + altitude),
          longitude + enu.x() / ((radii.transverse + altitude) * std::cos(latitude))};
}

const char* landmark_model_name(LandmarkModelKind kind) {
  return kind == LandmarkModelKind::kGeodetic ? "geodetic_landmarks" : "enu_landmarks";
}

HorizontalModel::HorizontalModel(LandmarkModelKind kind, OperatingArea area) : kind_(kind), area_(area) {
  if (kind_ == LandmarkModelKind::kGeodetic) {
    // Rows in state order (lat, lon), columns (east, north).
    position_per_metre_ << 0.0, 1.0 / (area_.radii.meridian + area_.altitude),
        1.0 / ((area_.radii.transverse + area_.altitude) * std::cos(area_.latitude)), 0.0;
  } else {
    position_per_metre_.setIdentity();
  }
}

HorizontalModel::State HorizontalModel::derivative(const State& x, const Eigen::Vector2d& force_enu) const {
  State g;
  if (kind_ == LandmarkModelKind::kEnu) {
    g << x(2), x(3), force_enu.x(), force_enu.y();
    return g;
  }
  const double lat = x(0), vN = x(2), vE = x(3);
  const double Rm = area_.radii.meridian + area_.altitude, Rt = area_.radii.transverse + area_.altitude;
  const double s = std::sin(lat), c = std::cos(lat), t = std::tan(lat);
  const double we = wgs84::kEarthRate;
  g << vN / Rm, vE / (Rt * c), force_enu.y() - 2.0 * we * vE * s - vE * vE * t / Rt,
      force_enu.x() + 2.0 * we * vN * s + vN * vE * t / Rm;
  return g;
}

HorizontalModel::StateMatrix HorizontalModel::derivative_jacobian(const State& x) const {
  StateMatrix J = StateMatrix::Zero();
  if (kind_ == LandmarkModelKind::kEnu) {
    J(0, 2) = 1.0;
    J(1, 3) = 1.0;
    return J;
  }
  const double lat = x(0), vN = x(2), vE = x(3);
  const double Rm = area_.radii.meridian + area_.altitude, Rt = area_.radii.transverse + area_.altitude;
  const double s = std::sin(lat), c = std::cos(lat), t = std::tan(lat), sec2 = 1.0 / (c * c);
  const double we = wgs84::kEarthRate;
  J(0, 2) = 1.0 / Rm;
  J(1, 0) = vE * s * sec2 / Rt;
  J(1, 3) = 1.0 / (Rt * c);
  J(2, 0) = -2.0 * we * vE * c - vE * vE * sec2 / Rt;
  J(2, 3) = -2.0 * we * s - 2.0 * vE * t / Rt;
  J(3, 0) = 2.0 * we * vN * c + vN * vE * sec2 / Rm;
  J(3, 2) = 2.0 * we * s + vE * t / Rm;
  J(3, 3) = vN * t / Rm;
  return J;
}

HorizontalModel::State HorizontalModel::predict(const State& x, const Eigen::Vector2d& force_enu, double dt) const {
  return x + dt * derivative(x, force_enu);
}

HorizontalModel::StateMatrix HorizontalModel::transition_jacobian(const State& x, double dt) const {
  return StateMatrix::Identity() + dt * derivative_jacobian(x);
}

Eigen::Vector2d HorizontalModel::landmark_position(double latitude_rad, double longitude_rad) const {
  if (kind_ == LandmarkModelKind::kGeodetic) return {latitude_rad, longitude_rad};
  return area_.to_enu(latitude_rad, longitude_rad);
}

HorizontalModel::State HorizontalModel::state_from_enu(const Eigen::Vector2d& position,
                                                       const Eigen::Vector2d& velocity) const {
  State x;
  if (kind_ == LandmarkModelKind::kEnu) {
    x << position, velocity;
  } else {
    const Eigen::Vector2d geodetic = area_.to_geodetic(position);
    x << geodetic, velocity.y(), velocity.x();
  }
  return x;
}

Eigen::Vector2d HorizontalModel::position_enu(const State& x) const {
  if (kind_ == LandmarkModelKind::kEnu) return x.head<2>();
  return area_.to_enu(x(0), x(1));
}

Eigen::Vector2d HorizontalModel::velocity_enu(const State& x) const {
  if (kind_ == LandmarkModelKind::kEnu) return x.tail<2>();
  return {x(3), x(2)};
}

HorizontalModel::StateMatrix HorizontalModel::enu_jacobian() const {
  if (kind_ == LandmarkModelKind::kEnu) return StateMatrix::Identity();
  StateMatrix J = StateMatrix::Zero();
  J(0, 1) = (area_.radii.transverse + area_.altitude) * std::cos(area_.latitude);
  J(1, 0) = area_.radii.meridian + area_.altitude;
  J(2, 3) = 1.0;
  J(3, 2) = 1.0;
  return J;
}

void body_to_horizontal(const Eigen::Quaterniond& attitude, const Eigen::Vector3d& position_body,
                        const Eigen::Matrix3d& covariance_body, Eigen::Vector2d* offset_enu,
                        Eigen::Matrix2d* covariance_enu) {
  const Eigen::Matrix<double, 2, 3> C = attitude.normalized().toRotationMatrix().topRows<2>();
  *offset_enu = C * position_body;
  *covariance_enu = C * covariance_body * C.transpose();
}

LandmarkMeasurement landmark_measurement(const HorizontalModel& model, const Eigen::Vector2d& offset_enu,
                                         const Eigen::Matrix2d& covariance_enu) {
  const Eigen::Matrix2d T = model.position_per_metre();
  return {T * offset_enu, T * covariance_enu * T.transpose()};
}

}  // namespace locd::feature_ekf
