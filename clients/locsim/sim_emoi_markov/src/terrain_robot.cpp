#include "locd/sim_emoi_markov/terrain_robot.hpp"

#include <cmath>
#include <stdexcept>

#include "locd/sdk/geometry.hpp"
#include "locd/sim_emoi_markov/synthetic_dsm.hpp"

namespace locd::sim::emoi {

TerrainRobot::TerrainRobot(const locd::emoi::ElevationMap& terrain, std::vector<Eigen::Vector2d> path,
                           double speed_mps, double base_height_m, OdometryErrorConfig odometry, ImuConfig imu,
                           uint64_t seed)
    : terrain_(terrain), path_(std::move(path)), speed_(speed_mps), base_height_(base_height_m),
      odometry_error_(odometry), imu_config_(imu), rng_(seed) {
  if (path_.size() < 2) throw std::invalid_argument("a robot path needs a start and at least one waypoint");
  for (const auto& p : path_) {
    if (!std::isfinite(elevation_at(terrain_, p))) throw std::invalid_argument("robot path leaves the map");
  }
  const Eigen::Vector2d d = path_[1] - path_[0];
  true_yaw_ = std::atan2(d.y(), d.x());
  start_leg();
}

void TerrainRobot::start_leg() {
  std::normal_distribution<double> unit(0.0, 1.0);
  leg_scale_ = 1.0 + odometry_error_.scale_stddev * unit(rng_);
  leg_drift_ = odometry_error_.drift_stddev_rad * unit(rng_);
}

void TerrainRobot::step(double dt) {
  if (finished_) return;
  double remaining = speed_ * dt;
  while (remaining > 0 && !finished_) {
    const Eigen::Vector2d a = path_[leg_], b = path_[leg_ + 1];
    const double length = (b - a).norm();
    const double ds = std::min(remaining, length - along_);
    along_ += ds;
    remaining -= ds;
    travelled_m_ += ds;
    // Odometry: the measured displacement is scaled and turned by this leg's errors.
    odom_position_ += leg_scale_ * ds * Eigen::Vector2d(std::cos(odom_yaw_ + leg_drift_), std::sin(odom_yaw_ + leg_drift_));
    if (along_ >= length - 1e-9) {
      ++leg_;
      along_ = 0.0;
      if (leg_ + 1 >= path_.size()) {
        finished_ = true;
        break;
      }
      const Eigen::Vector2d next = path_[leg_ + 1] - path_[leg_];
      const double turn = normalize_angle(std::atan2(next.y(), next.x()) - true_yaw_);
      true_yaw_ += turn;
      std::normal_distribution<double> unit(0.0, 1.0);
      odom_yaw_ += turn * (1.0 + odometry_error_.yaw_rate_stddev * unit(rng_));
      start_leg();
    }
  }
  time_s_ += dt;
}

Eigen::Isometry3d TerrainRobot::true_pose() const {
  const size_t leg = std::min(leg_, path_.size() - 2);
  const Eigen::Vector2d a = path_[leg], b = path_[leg + 1];
  const Eigen::Vector2d p = finished_ ? path_.back() : a + (b - a).normalized() * along_;
  const Eigen::Vector2d forward(std::cos(true_yaw_), std::sin(true_yaw_)), left(-forward.y(), forward.x());
  const double baseline = 0.5;
  auto ground = [&](const Eigen::Vector2d& q) {
    const double z = elevation_at(terrain_, q);
    return std::isfinite(z) ? z : elevation_at(terrain_, p);
  };
  const double slope_forward = (ground(p + forward * baseline) - ground(p - forward * baseline)) / (2 * baseline);
  const double slope_left = (ground(p + left * baseline) - ground(p - left * baseline)) / (2 * baseline);
  return isometry_from_xyz_rpy(p.x(), p.y(), ground(p) + base_height_, std::atan(slope_left),
                               -std::atan(slope_forward), true_yaw_);
}

Odometry TerrainRobot::odometry(int64_t stamp_ns) const {
  const Eigen::Isometry3d truth = true_pose();
  const Eigen::Vector3d rpy = roll_pitch_yaw(truth.linear());
  Odometry o;
  o.header.stamp_ns = stamp_ns;
  o.header.frame_id = "odom";
  // The odom frame starts at the start pose (position and heading); z is measured with the
  // inclinometer-aided 3D odometry and kept exact here.
  const double start_z = elevation_at(terrain_, path_[0]) + base_height_;
  o.pose = isometry_from_xyz_rpy(odom_position_.x(), odom_position_.y(), truth.translation().z() - start_z, rpy.x(),
                                 rpy.y(), odom_yaw_);
  o.linear_velocity = Eigen::Vector3d(finished_ ? 0.0 : speed_, 0, 0);
  return o;
}

Imu TerrainRobot::imu(int64_t stamp_ns) {
  const Eigen::Vector3d rpy = roll_pitch_yaw(true_pose().linear());
  std::normal_distribution<double> unit(0.0, 1.0);
  Imu m;
  m.header.stamp_ns = stamp_ns;
  m.header.frame_id = "base_link";
  m.orientation = quaternion_from_rpy(rpy.x() + imu_config_.tilt_stddev_rad * unit(rng_),
                                      rpy.y() + imu_config_.tilt_stddev_rad * unit(rng_),
                                      rpy.z() + imu_config_.yaw_stddev_rad * unit(rng_));
  m.orientation_stddev = imu_config_.yaw_stddev_rad;
  return m;
}

}  // namespace locd::sim::emoi
