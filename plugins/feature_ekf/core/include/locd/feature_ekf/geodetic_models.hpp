// The landmark models of Kim, Hong, Ra (2018), "non-unique landmarks" (issue 3): a horizontal
// state driven by the body acceleration rotated by the AHRS attitude (eq. 7-9) and the landmark's
// relative position mapped into the state's units (eq. 10-12). Two state layouts share the code:
//   geodetic: x = [lat, lon, vN, vE] (rad, rad, m/s, m/s), the paper's model with WGS84 radii at
//             the operating area's centre (eq. 8);
//   enu:      x = [east, north, vE, vN] (m, m/s) about the same centre, for robots in metres.
// Horizontal vectors outside the state (forces, landmark offsets, outputs) are always ENU (east,
// north) metres about the operating area's centre.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "locd/feature_ekf/config.hpp"

namespace locd::feature_ekf {

namespace wgs84 {
constexpr double kSemiMajorAxis = 6378137.0;          // m, R_e
constexpr double kEccentricity2 = 6.69437999014e-3;   // e^2
constexpr double kEarthRate = 7.292115e-5;            // rad/s, omega_e
}  // namespace wgs84

struct EarthRadii {
  double meridian = 0.0;    // R_m
  double transverse = 0.0;  // R_t
};
// Eq. 8.
EarthRadii earth_radii(double latitude_rad);

// Assumption A5: the vehicle stays near (latitude, longitude); A3: its altitude h is known.
struct OperatingArea {
  double latitude = 0.0;   // rad, lambda-bar
  double longitude = 0.0;  // rad, Lambda-bar
  double altitude = 0.0;   // m, h
  EarthRadii radii;

  static OperatingArea centred_at(double latitude_rad, double longitude_rad, double altitude_m);
  // Local metric coordinates about the centre, the flat mapping of eq. 10 with lambda-bar.
  Eigen::Vector2d to_enu(double latitude_rad, double longitude_rad) const;
  Eigen::Vector2d to_geodetic(const Eigen::Vector2d& enu) const;  // (lat, lon) rad
};

const char* landmark_model_name(LandmarkModelKind kind);  // "geodetic_landmarks", "enu_landmarks"

class HorizontalModel {
 public:
  using State = Eigen::Vector4d;
  using StateMatrix = Eigen::Matrix4d;

  HorizontalModel(LandmarkModelKind kind, OperatingArea area);

  LandmarkModelKind kind() const { return kind_; }
  const OperatingArea& area() const { return area_; }

  // Eq. 7: x' = g(x) for a horizontal specific force (east, north) in m/s^2, gravity removed.
  State derivative(const State& x, const Eigen::Vector2d& force_enu) const;
  StateMatrix derivative_jacobian(const State& x) const;  // dg/dx (g is affine in the force)
  // Eq. 9: f(x) = x + Ts g(x) and F = df/dx.
  State predict(const State& x, const Eigen::Vector2d& force_enu, double dt) const;
  StateMatrix transition_jacobian(const State& x, double dt) const;

  // Eq. 10: the state-unit offset per ENU metre, diag(1/R_m, sec(lambda-bar)/R_t) with the rows
  // in state order (the C_B^N part is applied by the caller: offsets arrive in ENU).
  Eigen::Matrix2d position_per_metre() const { return position_per_metre_; }
  // A landmark's position in state units.
  Eigen::Vector2d landmark_position(double latitude_rad, double longitude_rad) const;

  // Outputs in ENU metres about the centre, and their Jacobians w.r.t. the state.
  State state_from_enu(const Eigen::Vector2d& position, const Eigen::Vector2d& velocity) const;
  Eigen::Vector2d position_enu(const State& x) const;
  Eigen::Vector2d velocity_enu(const State& x) const;
  StateMatrix enu_jacobian() const;  // d[E, N, vE, vN]/dx (constant)

 private:
  LandmarkModelKind kind_;
  OperatingArea area_;
  Eigen::Matrix2d position_per_metre_;
};

// Eq. 10-12 for one detection: y = l - T z, H = [I 0], R = T R_p T^T.
struct LandmarkMeasurement {
  Eigen::Vector2d offset;      // T z: the landmark's offset from the vehicle in state units
  Eigen::Matrix2d covariance;  // R, state units
};

// The horizontal ENU offset and its covariance from a body-frame position and covariance, with
// the attitude of base_link in ENU (the C_B^N of eq. 10, assumption A6: the height is dropped).
void body_to_horizontal(const Eigen::Quaterniond& attitude, const Eigen::Vector3d& position_body,
                        const Eigen::Matrix3d& covariance_body, Eigen::Vector2d* offset_enu,
                        Eigen::Matrix2d* covariance_enu);

LandmarkMeasurement landmark_measurement(const HorizontalModel& model, const Eigen::Vector2d& offset_enu,
                                         const Eigen::Matrix2d& covariance_enu);

}  // namespace locd::feature_ekf
