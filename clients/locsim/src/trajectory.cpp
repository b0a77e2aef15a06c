#include "locd/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "locd/sdk/errors.hpp"

namespace locd::sim {

WaypointPath::WaypointPath(std::vector<Eigen::Vector2d> waypoints, bool loop)
    : points_(std::move(waypoints)), loop_(loop) {
  if (points_.size() < 2) throw std::invalid_argument("WaypointPath: needs at least 2 waypoints");
  if (loop_) points_.push_back(points_.front());
  cumulative_.push_back(0.0);
  for (size_t i = 1; i < points_.size(); ++i) cumulative_.push_back(cumulative_.back() + (points_[i] - points_[i - 1]).norm());
}

Eigen::Vector2d WaypointPath::point_at(double s) const {
  const double total = length();
  if (loop_) {
    s = std::fmod(s, total);
    if (s < 0) s += total;
  } else {
    s = std::clamp(s, 0.0, total);
  }
  const size_t i = std::min<size_t>(
      std::upper_bound(cumulative_.begin(), cumulative_.end(), s) - cumulative_.begin(), cumulative_.size() - 1);
  const size_t k = i == 0 ? 1 : i;
  const double span = cumulative_[k] - cumulative_[k - 1];
  const double u = span > 0 ? (s - cumulative_[k - 1]) / span : 0.0;
  return points_[k - 1] + std::clamp(u, 0.0, 1.0) * (points_[k] - points_[k - 1]);
}

double WaypointPath::project(const Eigen::Vector2d& p, double s_from, double s_to) const {
  const double total = length();
  if (!loop_) {
    s_from = std::max(s_from, 0.0);
    s_to = std::min(s_to, total);
  }
  double best_s = s_from, best_d = std::numeric_limits<double>::infinity();
  // Every segment piece overlapping [s_from, s_to], each projected exactly.
  const double offset_first = loop_ ? std::floor(s_from / total) * total : 0.0;
  for (double offset = offset_first; offset <= s_to; offset += total) {
    for (size_t k = 1; k < points_.size(); ++k) {
      const double lo = std::max(offset + cumulative_[k - 1], s_from);
      const double hi = std::min(offset + cumulative_[k], s_to);
      if (lo > hi) continue;
      const Eigen::Vector2d a = points_[k - 1], e = points_[k] - points_[k - 1];
      const double span = e.norm();
      double s = offset + cumulative_[k - 1] + std::clamp((p - a).dot(e) / (span * span), 0.0, 1.0) * span;
      s = std::clamp(s, lo, hi);
      const double d = (point_at(s) - p).squaredNorm();
      if (d < best_d) {
        best_d = d;
        best_s = s;
      }
    }
    if (!loop_) break;
  }
  return best_s;
}

double WaypointPath::heading_at(double s) const {
  constexpr double kStep = 1e-3;  // m: the direction of the chord around s
  const Eigen::Vector2d d = point_at(s + kStep) - point_at(s - kStep);
  if (d.squaredNorm() > 0.0) return std::atan2(d.y(), d.x());
  const Eigen::Vector2d ahead = point_at(s + kStep) - point_at(s);  // the end of an open path
  const Eigen::Vector2d behind = point_at(s) - point_at(s - kStep);
  const Eigen::Vector2d e = ahead.squaredNorm() > 0.0 ? ahead : behind;
  return std::atan2(e.y(), e.x());
}

Pose2 random_route_pose(const RobotSpec& robot, const Eigen::Vector2d& away_from, double min_distance_m,
                        std::mt19937_64& rng, const std::string& what) {
  const WaypointPath path(robot.waypoints, robot.loop);
  // Arc-length intervals of the route far enough, at a 1 cm resolution, then a uniform draw.
  constexpr double kStep = 0.01;
  std::vector<double> far;
  for (double s = 0.0; s < path.length(); s += kStep) {
    if ((path.point_at(s) - away_from).norm() >= min_distance_m) far.push_back(s);
  }
  if (far.empty()) {
    throw ConfigError(what + ": no point of the robot's route is " + std::to_string(min_distance_m) +
                      " m or more from (" + std::to_string(away_from.x()) + ", " + std::to_string(away_from.y()) + ")");
  }
  std::uniform_int_distribution<size_t> pick(0, far.size() - 1);
  std::uniform_real_distribution<double> within(0.0, kStep);
  double s = far[pick(rng)] + within(rng);
  if ((path.point_at(s) - away_from).norm() < min_distance_m) s = far[pick(rng)];  // stay in the far set
  const Eigen::Vector2d p = path.point_at(s);
  return {p.x(), p.y(), path.heading_at(s)};
}

Trajectory Trajectory::generate(const RobotSpec& robot, double duration_s, double sample_period_s,
                                const std::optional<Teleport>& teleport) {
  if (!(sample_period_s > 0)) throw std::invalid_argument("Trajectory: sample period must be positive");
  const WaypointPath path(robot.waypoints, robot.loop);
  Trajectory trajectory;
  trajectory.period_ = sample_period_s;
  Pose2 pose = robot.start;
  Pose2 driven = robot.start;
  bool teleport_pending = teleport.has_value();
  double v = 0.0;
  double s = path.project({pose.x, pose.y}, 0.0, path.length());
  const size_t steps = static_cast<size_t>(std::floor(duration_s / sample_period_s + 1e-9));
  trajectory.samples_.reserve(steps + 1);
  for (size_t k = 0; k <= steps; ++k) {
    const double dt = sample_period_s;
    const double t = static_cast<double>(k) * sample_period_s;
    bool teleported = false;
    if (teleport_pending && t >= teleport->at_s - 1e-9) {
      teleport_pending = false;
      teleported = true;
      pose = teleport->to;
      s = path.project({pose.x, pose.y}, 0.0, path.length());
    }
    s = path.project({pose.x, pose.y}, s - 0.5, s + 2.0 * robot.lookahead + 0.5);
    const double remaining = path.loop() ? std::numeric_limits<double>::infinity() : path.length() - s;
    const Eigen::Vector2d target = path.point_at(s + robot.lookahead);
    const Eigen::Vector2d local = Pose2(pose.x, pose.y, pose.theta).inverse().transform(target);
    const double distance2 = std::max(local.squaredNorm(), 1e-6);
    double curvature = 2.0 * local.y() / distance2;  // pure pursuit: kappa = 2 y / L^2
    double v_target = robot.max_speed;
    if (std::abs(curvature) > 1e-9) v_target = std::min(v_target, robot.max_yaw_rate / std::abs(curvature));
    if (local.x() < 0) v_target = 0.0;  // target behind: turn in place
    // Stop at the end of an open path with the deceleration available.
    v_target = std::min(v_target, std::sqrt(2.0 * robot.max_acceleration * std::max(remaining - 0.05, 0.0)));
    double omega;
    if (local.x() < 0) {
      omega = std::copysign(robot.max_yaw_rate, local.y());
    } else {
      omega = std::clamp(v * curvature, -robot.max_yaw_rate, robot.max_yaw_rate);
    }
    if (!path.loop() && remaining < 0.05) omega = 0.0;

    TruthSample sample;
    sample.t = t;
    sample.pose = pose;
    sample.driven = driven;
    sample.teleported = teleported;
    sample.linear_velocity = v;
    sample.angular_velocity = omega;
    trajectory.samples_.push_back(sample);

    // Exact unicycle step with constant (v, omega) over dt: a chord of length
    // v dt sin(omega dt / 2) / (omega dt / 2) along the mean heading (stable as omega -> 0).
    const double half_turn = 0.5 * omega * dt;
    const double chord = v * dt * (std::abs(half_turn) > 1e-9 ? std::sin(half_turn) / half_turn : 1.0);
    for (Pose2* p : {&pose, &driven}) {
      p->x += chord * std::cos(p->theta + half_turn);
      p->y += chord * std::sin(p->theta + half_turn);
      p->theta = normalize_angle(p->theta + omega * dt);
    }
    const double dv = std::clamp(v_target - v, -robot.max_acceleration * dt, robot.max_acceleration * dt);
    v += dv;
  }
  return trajectory;
}

TruthSample Trajectory::at(double t) const {
  if (samples_.empty()) return {};
  if (t <= samples_.front().t) return samples_.front();
  if (t >= samples_.back().t) return samples_.back();
  const size_t i = std::min(static_cast<size_t>(t / period_), samples_.size() - 2);
  const TruthSample& a = samples_[i];
  const TruthSample& b = samples_[i + 1];
  const double u = std::clamp((t - a.t) / (b.t - a.t), 0.0, 1.0);
  TruthSample out;
  out.t = t;
  const auto interpolate = [u](const Pose2& p, const Pose2& q) {
    return Pose2(p.x + u * (q.x - p.x), p.y + u * (q.y - p.y), normalize_angle(p.theta + u * normalize_angle(q.theta - p.theta)));
  };
  out.pose = b.teleported ? (u < 1.0 ? a.pose : b.pose) : interpolate(a.pose, b.pose);
  out.driven = interpolate(a.driven.value_or(a.pose), b.driven.value_or(b.pose));
  out.linear_velocity = a.linear_velocity + u * (b.linear_velocity - a.linear_velocity);
  out.angular_velocity = a.angular_velocity + u * (b.angular_velocity - a.angular_velocity);
  return out;
}

}  // namespace locd::sim
