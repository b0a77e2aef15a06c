#include "locd/ceiling_pf/velocity_motion_model.hpp"

#include <cmath>

namespace locd::ceiling_pf {

namespace {
constexpr double kStraight = 1e-9;  // |omega dt| below this: straight-line limit
}

VelocityCommand velocity_between(const Pose2& from, const Pose2& to, double dt) {
  VelocityCommand u;
  u.dt = dt;
  if (!(dt > 0.0)) return u;
  const Pose2 delta = from.inverse() * to;  // body frame of `from`
  const double dtheta = normalize_angle(delta.theta);
  const double chord = std::hypot(delta.x, delta.y);
  const double sign = delta.x >= 0.0 ? 1.0 : -1.0;
  u.angular = dtheta / dt;
  // Arc length from the chord: s = chord * (dtheta / 2) / sin(dtheta / 2).
  const double half = 0.5 * dtheta;
  const double arc = std::abs(half) < 1e-6 ? chord : chord * half / std::sin(half);
  u.linear = sign * arc / dt;
  return u;
}

VelocityMotionModel::VelocityMotionModel(MotionNoise alpha) : alpha_(alpha) {}

Pose2 VelocityMotionModel::move(const Pose2& pose, double v, double w, double gamma, double dt) {
  Pose2 next;
  if (std::abs(w * dt) < kStraight) {
    next.x = pose.x + v * dt * std::cos(pose.theta);
    next.y = pose.y + v * dt * std::sin(pose.theta);
  } else {
    const double r = v / w;
    next.x = pose.x - r * std::sin(pose.theta) + r * std::sin(pose.theta + w * dt);
    next.y = pose.y + r * std::cos(pose.theta) - r * std::cos(pose.theta + w * dt);
  }
  next.theta = normalize_angle(pose.theta + w * dt + gamma * dt);
  return next;
}

Pose2 VelocityMotionModel::sample(const Pose2& pose, const VelocityCommand& u, std::mt19937_64& rng) const {
  const double v2 = u.linear * u.linear, w2 = u.angular * u.angular;
  const double v = u.linear + (alpha_[0] * v2 + alpha_[1] * w2) * normal_(rng);
  const double w = u.angular + (alpha_[2] * v2 + alpha_[3] * w2) * normal_(rng);
  const double gamma = (alpha_[4] * v2 + alpha_[5] * w2) * normal_(rng);
  return move(pose, v, w, gamma, u.dt);
}

}  // namespace locd::ceiling_pf
