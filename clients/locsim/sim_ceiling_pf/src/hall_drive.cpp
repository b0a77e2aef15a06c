#include "locd/sim_ceiling_pf/hall_drive.hpp"

#include <algorithm>
#include <cmath>

namespace locd::sim::ceiling {

std::vector<Eigen::Vector2d> paper_waypoints() {
  return {{30.38, 27.2}, {37.47, 27.32}, {75.11, 27.63}, {75.03, 38.85},
          {36.13, 39.01}, {19.87, 38.49}, {18.81, 27.56}};
}

namespace {
Pose2 arc(const Pose2& p, double v, double w, double gamma, double dt) {
  Pose2 n;
  if (std::abs(w * dt) < 1e-9) {
    n.x = p.x + v * dt * std::cos(p.theta);
    n.y = p.y + v * dt * std::sin(p.theta);
  } else {
    n.x = p.x - v / w * std::sin(p.theta) + v / w * std::sin(p.theta + w * dt);
    n.y = p.y + v / w * std::cos(p.theta) - v / w * std::cos(p.theta + w * dt);
  }
  n.theta = normalize_angle(p.theta + w * dt + gamma * dt);
  return n;
}
}  // namespace

HallDrive::HallDrive(const DriveConfig& drive, const CeilingCameraRenderer& camera, uint64_t seed,
                     std::optional<Pose2> start, bool render_images)
    : config_(drive),
      camera_(camera),
      render_images_(render_images),
      truth_rng_(seed * 3 + 1),
      odometry_rng_(seed * 3 + 2),
      camera_rng_(seed * 3 + 3) {
  if (config_.return_to_start && !config_.waypoints.empty()) config_.waypoints.push_back(config_.waypoints.front());
  if (start) {
    truth_.pose = *start;
  } else if (config_.waypoints.size() >= 2) {
    const Eigen::Vector2d d = config_.waypoints[1] - config_.waypoints[0];
    truth_.pose = Pose2(config_.waypoints[0].x(), config_.waypoints[0].y(), std::atan2(d.y(), d.x()));
    truth_.waypoint = 1;
  }
  odom_pose_ = Pose2(0, 0, 0);
}

void HallDrive::step_truth() {
  const double dt = config_.step;
  if (truth_.waypoint >= static_cast<int>(config_.waypoints.size())) {
    truth_.linear = truth_.angular = 0.0;
    done_ = true;
  } else {
    const Eigen::Vector2d target = config_.waypoints[truth_.waypoint];
    const Eigen::Vector2d to = target - Eigen::Vector2d(truth_.pose.x, truth_.pose.y);
    const double error = normalize_angle(std::atan2(to.y(), to.x()) - truth_.pose.theta);
    truth_.angular = std::clamp(2.0 * error, -config_.max_yaw_rate, config_.max_yaw_rate);
    const double along = std::cos(error);
    truth_.linear = std::abs(error) > M_PI / 3 ? 0.0 : config_.max_speed * along * along;
    truth_.linear = std::min(truth_.linear, to.norm() / dt);
  }
  truth_.pose = arc(truth_.pose, truth_.linear, truth_.angular, 0.0, dt);
  truth_.t += dt;
  odometry_v_sum_ += truth_.linear;
  odometry_w_sum_ += truth_.angular;
  ++steps_since_odometry_;
  if (truth_.waypoint < static_cast<int>(config_.waypoints.size())) {
    const Eigen::Vector2d target = config_.waypoints[truth_.waypoint];
    if ((target - Eigen::Vector2d(truth_.pose.x, truth_.pose.y)).norm() < config_.waypoint_tolerance) {
      pending_waypoint_ = truth_.waypoint;
      ++truth_.waypoint;
    }
  }
}

Odometry HallDrive::odometry() {
  // The wheels' mean (v, omega) over the period, reported with the paper's velocity noise
  // (standard deviations alpha_i v^2 + alpha_j omega^2) and integrated in the odom frame.
  const double dt = steps_since_odometry_ * config_.step;
  const double v = steps_since_odometry_ ? odometry_v_sum_ / steps_since_odometry_ : 0.0;
  const double w = steps_since_odometry_ ? odometry_w_sum_ / steps_since_odometry_ : 0.0;
  const auto& a = config_.odometry_alpha;
  std::normal_distribution<double> normal(0.0, 1.0);
  const double vn = v + (a[0] * v * v + a[1] * w * w) * normal(odometry_rng_);
  const double wn = w + (a[2] * v * v + a[3] * w * w) * normal(odometry_rng_);
  const double gn = (a[4] * v * v + a[5] * w * w) * normal(odometry_rng_);
  if (dt > 0.0) odom_pose_ = arc(odom_pose_, vn, wn, gn, dt);
  odometry_v_sum_ = odometry_w_sum_ = 0.0;
  steps_since_odometry_ = 0;
  Odometry o;
  o.header.frame_id = "odom";
  o.pose = odom_pose_.to_isometry();
  o.linear_velocity = Eigen::Vector3d(vn, 0.0, 0.0);
  o.angular_velocity = Eigen::Vector3d(0.0, 0.0, wn + gn);
  return o;
}

std::optional<DriveEvent> HallDrive::next(double max_time) {
  if (done_) return std::nullopt;
  const double odometry_period = 1.0 / config_.odometry_rate_hz;
  const double camera_period = 1.0 / camera_.config().rate_hz;
  const double next_time = std::min(next_odometry_, next_camera_);
  if (next_time > max_time) return std::nullopt;
  while (truth_.t + 0.5 * config_.step < next_time && !done_) step_truth();
  DriveEvent event;
  event.t = truth_.t;
  event.truth = truth_.pose;
  const int64_t stamp = origin_ns_ + static_cast<int64_t>(std::llround(event.t * 1e9));
  if (next_odometry_ <= next_camera_) {
    Odometry o = odometry();
    o.header.stamp_ns = stamp;
    event.measurement = o;
    next_odometry_ += odometry_period;
  } else {
    if (render_images_) {
      event.measurement = camera_.image(truth_.pose, stamp, camera_rng_);
    } else {
      LandmarkDetections frame;
      frame.header.stamp_ns = stamp;
      frame.header.frame_id = "base_link";
      for (const Eigen::Vector2d& p : visible_points()) {
        LandmarkDetection d;
        d.class_label = "ceiling_light";
        d.position = Eigen::Vector3d(p.x(), p.y(), 0.0);
        frame.detections.push_back(d);
      }
      event.measurement = frame;
    }
    next_camera_ += camera_period;
  }
  event.reached_waypoint = pending_waypoint_;
  pending_waypoint_ = -1;
  return event;
}

std::vector<Eigen::Vector2d> HallDrive::visible_points() const {
  std::vector<Eigen::Vector2d> points;
  for (const VisibleLandmark& v : camera_.visible(truth_.pose)) points.push_back(v.in_base);
  return points;
}

}  // namespace locd::sim::ceiling
