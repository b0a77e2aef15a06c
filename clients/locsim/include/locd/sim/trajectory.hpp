// The robot's true motion: a pure-pursuit controller (Coulter, "Implementation of the Pure
// Pursuit Path Tracking Algorithm", 1992) following the waypoint polyline, a unicycle
// integrated exactly over each step, speed limited by max_speed, max_acceleration and, in turns,
// by max_yaw_rate (v <= max_yaw_rate / |curvature|).
#pragma once

#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sim/scenario.hpp"

namespace locd::sim {

struct TruthSample {
  double t = 0.0;  // s since the start
  Pose2 pose;
  double linear_velocity = 0.0;   // m/s, body x
  double angular_velocity = 0.0;  // rad/s
};

// The waypoint polyline with arc-length parameterisation (closed when looping).
class WaypointPath {
 public:
  WaypointPath(std::vector<Eigen::Vector2d> waypoints, bool loop);
  double length() const { return cumulative_.back(); }
  bool loop() const { return loop_; }
  Eigen::Vector2d point_at(double s) const;  // s wrapped (loop) or clamped
  // Arc length of the point nearest to p, searched in [s_from, s_to] (unwrapped).
  double project(const Eigen::Vector2d& p, double s_from, double s_to) const;

 private:
  std::vector<Eigen::Vector2d> points_;  // closed loop repeats the first point at the end
  std::vector<double> cumulative_;
  bool loop_;
};

class Trajectory {
 public:
  // Samples every sample_period_s from t = 0 to duration_s inclusive.
  static Trajectory generate(const RobotSpec& robot, double duration_s, double sample_period_s);

  const std::vector<TruthSample>& samples() const { return samples_; }
  double sample_period() const { return period_; }
  // Interpolated truth at time t (clamped to the sampled span).
  TruthSample at(double t) const;

 private:
  std::vector<TruthSample> samples_;
  double period_ = 0.02;
};

}  // namespace locd::sim
