// The robot's true motion: a pure-pursuit controller (Coulter, "Implementation of the Pure
// Pursuit Path Tracking Algorithm", 1992) following the waypoint polyline, a unicycle
// integrated exactly over each step, speed limited by max_speed, max_acceleration and, in turns,
// by max_yaw_rate (v <= max_yaw_rate / |curvature|).
#pragma once

#include <optional>
#include <random>
#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sim/scenario.hpp"

namespace locd::sim {

struct TruthSample {
  double t = 0.0;  // s since the start
  Pose2 pose;
  double linear_velocity = 0.0;   // m/s, body x
  double angular_velocity = 0.0;  // rad/s
  // The pose integrated from the robot's own motion only, in a frame a kidnap does not move: what
  // its wheels see. Equal to pose until a kidnap; unset means equal to pose.
  std::optional<Pose2> driven;
  bool teleported = false;  // the robot was carried here since the previous sample
};

// A kidnap: at at_s the robot is carried to `to` (its motion carries on from there).
struct Teleport {
  double at_s = 0.0;
  Pose2 to;
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
  // Direction of travel at s (rad).
  double heading_at(double s) const;

 private:
  std::vector<Eigen::Vector2d> points_;  // closed loop repeats the first point at the end
  std::vector<double> cumulative_;
  bool loop_;
};

class Trajectory {
 public:
  // Samples every sample_period_s from t = 0 to duration_s inclusive; with a teleport, the first
  // sample at or after its time is at its pose.
  static Trajectory generate(const RobotSpec& robot, double duration_s, double sample_period_s,
                             const std::optional<Teleport>& teleport = std::nullopt);

  const std::vector<TruthSample>& samples() const { return samples_; }
  double sample_period() const { return period_; }
  // Interpolated truth at time t (clamped to the sampled span); across a teleport the pose is the
  // earlier sample's (the robot is not halfway between the two places), `driven` interpolated.
  TruthSample at(double t) const;

 private:
  std::vector<TruthSample> samples_;
  double period_ = 0.02;
};

// A pose on the robot's route (a point of the waypoint polyline, heading along it) drawn uniformly
// by arc length among those at least min_distance_m from `away_from`. Throws ConfigError naming
// `what` when no point of the route is that far.
Pose2 random_route_pose(const RobotSpec& robot, const Eigen::Vector2d& away_from, double min_distance_m,
                        std::mt19937_64& rng, const std::string& what);

}  // namespace locd::sim
