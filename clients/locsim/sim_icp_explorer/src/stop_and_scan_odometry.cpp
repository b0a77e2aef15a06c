#include "locd/sim_icp_explorer/stop_and_scan_odometry.hpp"

#include <cmath>

namespace locd::sim {

StopAndScanOdometry::StopAndScanOdometry(const StopAndScanOdometryConfig& config) : config_(config) {}

Odometry StopAndScanOdometry::arrive(const Pose2& truth, int64_t stamp_ns, std::mt19937_64& rng) {
  if (!started_) {
    started_ = true;
    odom_ = truth;
  } else {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const double radius = config_.max_translation_error * std::sqrt(unit(rng));
    const double direction = 2.0 * M_PI * unit(rng);
    const double yaw = config_.max_rotation_error * (2.0 * unit(rng) - 1.0);
    const Pose2 error(radius * std::cos(direction), radius * std::sin(direction), yaw);
    odom_ = odom_ * (last_truth_.inverse() * truth) * error;
  }
  last_truth_ = truth;
  Odometry o;
  o.header.stamp_ns = stamp_ns;
  o.header.frame_id = "odom";
  o.pose = odom_.to_isometry();
  return o;
}

}  // namespace locd::sim
