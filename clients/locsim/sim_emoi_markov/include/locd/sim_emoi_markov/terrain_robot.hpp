// A robot driving a waypoint polyline on terrain at constant speed (turning on the spot at
// waypoints), its true 3D pose (z and attitude from the ground), odometry with a per-leg scale
// and drift error (the paper's "10 % odometry error"), and an IMU (attitude and heading).
#pragma once

#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "locd/emoi_markov/dsm_io.hpp"
#include "locd/sdk/params.hpp"
#include "locd/sdk/types.hpp"

namespace locd::sim::emoi {

struct OdometryErrorConfig {
  double scale_stddev = 0.1;        // per leg, relative distance error
  double drift_stddev_rad = 0.1;    // per leg, direction error of the measured displacement
  double yaw_rate_stddev = 0.002;   // rad per rad turned, odometry yaw
};

struct ImuConfig {
  double yaw_stddev_rad = 0.01;
  double tilt_stddev_rad = 0.005;
};

class TerrainRobot {
 public:
  TerrainRobot(const locd::emoi::ElevationMap& terrain, std::vector<Eigen::Vector2d> path, double speed_mps,
               double base_height_m, OdometryErrorConfig odometry, ImuConfig imu, uint64_t seed);

  bool finished() const { return finished_; }
  double time_s() const { return time_s_; }
  double travelled_m() const { return travelled_m_; }
  // Advances by dt (moves along the path), integrating the odometry with its errors.
  void step(double dt);

  Eigen::Isometry3d true_pose() const;           // base_link in map
  Odometry odometry(int64_t stamp_ns) const;     // base_link in odom (odom = map at start)
  Imu imu(int64_t stamp_ns);                     // attitude with noise, heading (map frame)

 private:
  void start_leg();
  const locd::emoi::ElevationMap& terrain_;
  std::vector<Eigen::Vector2d> path_;
  double speed_, base_height_;
  OdometryErrorConfig odometry_error_;
  ImuConfig imu_config_;
  std::mt19937_64 rng_;
  size_t leg_ = 0;
  double along_ = 0.0;     // distance along the current leg
  double time_s_ = 0.0, travelled_m_ = 0.0;
  bool finished_ = false;
  double leg_scale_ = 1.0, leg_drift_ = 0.0;
  Eigen::Vector2d odom_position_ = Eigen::Vector2d::Zero();
  double odom_yaw_ = 0.0;
  double true_yaw_ = 0.0;
};

}  // namespace locd::sim::emoi
