// A robot driving the paper's route through the hall: truth at a fixed step from a heading
// controller through waypoints, wheel odometry with the paper's velocity-model noise
// (alpha1..alpha6, Table 3), and the camera frames, all in stamp order from one seed.
#pragma once

#include <array>
#include <optional>
#include <random>
#include <variant>
#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/types.hpp"
#include "locd/sim_ceiling_pf/ceiling_world.hpp"

namespace locd::sim::ceiling {

// The paper's waypoints W1..W7 (Table 4), in the hall's frame.
std::vector<Eigen::Vector2d> paper_waypoints();

struct DriveConfig {
  std::vector<Eigen::Vector2d> waypoints = paper_waypoints();
  bool return_to_start = true;   // W7 -> W1 closes the loop (about 134 m, as in the paper)
  double max_speed = 0.36;       // m/s (paper: mean 0.36, max 0.4)
  double max_yaw_rate = 0.7;     // rad/s
  double step = 0.01;            // s, truth integration
  double odometry_rate_hz = 20.0;
  std::array<double, 6> odometry_alpha{0.3, 0.3, 0.1, 0.25, 0.001, 0.001};
  double waypoint_tolerance = 0.05;  // m
};

struct TruthState {
  double t = 0.0;
  Pose2 pose;
  double linear = 0.0, angular = 0.0;
  int waypoint = 0;  // index of the waypoint being driven to
};

struct DriveEvent {
  double t = 0.0;
  Pose2 truth;
  Measurement measurement;     // Odometry or Image
  int reached_waypoint = -1;   // >= 0: the truth passed this waypoint at this event
};

class HallDrive {
 public:
  HallDrive(const DriveConfig& drive, const CeilingCameraRenderer& camera, uint64_t seed,
            std::optional<Pose2> start = std::nullopt, bool render_images = true);

  // The next odometry or camera event, nullopt when the route is done or max_time passed.
  std::optional<DriveEvent> next(double max_time);
  const TruthState& truth() const { return truth_; }
  // Teleports the robot (kidnapping); odometry does not see it.
  void teleport(const Pose2& pose) { truth_.pose = pose; }
  // Detections of the current frame as ceiling_pf would get them from an on-board detector:
  // visible landmark centres in base_link.
  std::vector<Eigen::Vector2d> visible_points() const;

 private:
  void step_truth();
  Odometry odometry();

  DriveConfig config_;
  const CeilingCameraRenderer& camera_;
  bool render_images_;
  std::mt19937_64 truth_rng_, odometry_rng_, camera_rng_;
  TruthState truth_;
  Pose2 odom_pose_;
  double next_odometry_ = 0.0, next_camera_ = 0.0;
  double odometry_v_sum_ = 0.0, odometry_w_sum_ = 0.0;
  int steps_since_odometry_ = 0;
  int pending_waypoint_ = -1;
  bool done_ = false;
  int64_t origin_ns_ = 1'000'000'000;
};

}  // namespace locd::sim::ceiling
