// Odometry of a robot that drives from one scan stop to the next: each leg's odometry increment
// is the true increment composed with an error drawn uniformly within the bounds (translation in
// a disc of radius max_translation_error, yaw in [-max_rotation_error, max_rotation_error]).
#pragma once

#include <random>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/types.hpp"

namespace locd::sim {

struct StopAndScanOdometryConfig {
  double max_translation_error = 0.5;             // m per leg
  double max_rotation_error = 10.0 * M_PI / 180;  // rad per leg
};

class StopAndScanOdometry {
 public:
  explicit StopAndScanOdometry(const StopAndScanOdometryConfig& config);

  // The odometry reported when the robot stops at `truth` (the first call reports the start as
  // the odom origin: odom frame = truth frame at the first stop).
  Odometry arrive(const Pose2& truth, int64_t stamp_ns, std::mt19937_64& rng);
  const Pose2& odometry_pose() const { return odom_; }

 private:
  StopAndScanOdometryConfig config_;
  bool started_ = false;
  Pose2 last_truth_;
  Pose2 odom_;
};

}  // namespace locd::sim
