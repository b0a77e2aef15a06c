#include "locd/sim/odometry_model.hpp"

#include <cmath>

namespace locd::sim {

OdometryConfig OdometryConfig::from_params(const Params& p) {
  p.expect_only({"rate_hz", "drift", "frame_id"});
  OdometryConfig c;
  c.rate_hz = p.number("rate_hz", c.rate_hz, Range{0.0, 10000.0, true, false});
  c.frame_id = p.text("frame_id", c.frame_id);
  const Params d = p.child("drift");
  d.expect_only({"translation_fraction", "rotation_deg_per_metre", "rotation_fraction", "translation_scale_error",
                 "rotation_scale_error"});
  c.drift.translation_fraction = d.number("translation_fraction", c.drift.translation_fraction, Range{0.0, 1.0});
  c.drift.rotation_deg_per_metre = d.number("rotation_deg_per_metre", c.drift.rotation_deg_per_metre, Range{0.0, 90.0});
  c.drift.rotation_fraction = d.number("rotation_fraction", c.drift.rotation_fraction, Range{0.0, 1.0});
  c.drift.translation_scale_error =
      d.number("translation_scale_error", c.drift.translation_scale_error, Range{-0.5, 0.5});
  c.drift.rotation_scale_error = d.number("rotation_scale_error", c.drift.rotation_scale_error, Range{-0.5, 0.5});
  return c;
}

OdometryModel::OdometryModel(const OdometryConfig& config) : config_(config) {}

OdometryIncrement OdometryModel::increment_between(const Pose2& from, const Pose2& to) {
  const Pose2 delta = from.inverse() * to;
  OdometryIncrement inc;
  inc.distance = std::hypot(delta.x, delta.y);
  inc.direction = inc.distance > 0 ? std::atan2(delta.y, delta.x) : 0.0;
  inc.rotation = delta.theta;
  return inc;
}

OdometryIncrement OdometryModel::noisy(const OdometryIncrement& truth, std::mt19937_64& rng) const {
  const OdometryDrift& d = config_.drift;
  const double distance = std::abs(truth.distance);
  const double rotation_per_metre = d.rotation_deg_per_metre * M_PI / 180.0;
  const double translation_sigma = d.translation_fraction * std::sqrt(distance);
  const double rotation_sigma = std::sqrt(rotation_per_metre * rotation_per_metre * distance +
                                          d.rotation_fraction * d.rotation_fraction * std::abs(truth.rotation));
  std::normal_distribution<double> normal(0.0, 1.0);
  OdometryIncrement out = truth;
  out.distance = truth.distance * (1.0 + d.translation_scale_error) + translation_sigma * normal(rng);
  out.rotation = truth.rotation * (1.0 + d.rotation_scale_error) + rotation_sigma * normal(rng);
  return out;
}

Measurement OdometryModel::measure(const TruthSample& truth, int64_t stamp_ns, std::mt19937_64& rng) {
  Odometry o;
  o.header.stamp_ns = stamp_ns;
  o.header.frame_id = config_.frame_id;
  if (started_) {
    const OdometryIncrement reported = noisy(increment_between(last_truth_, truth.driven.value_or(truth.pose)), rng);
    const Pose2 step(reported.distance * std::cos(reported.direction), reported.distance * std::sin(reported.direction),
                     reported.rotation);
    odom_pose_ = odom_pose_ * step;
    const double dt = truth.t - last_t_;
    if (dt > 0) {
      o.linear_velocity = Eigen::Vector3d(step.x / dt, step.y / dt, 0.0);
      o.angular_velocity = Eigen::Vector3d(0.0, 0.0, reported.rotation / dt);
    }
  }
  started_ = true;
  last_truth_ = truth.driven.value_or(truth.pose);  // a kidnap moves pose, not what the wheels see
  last_t_ = truth.t;
  o.pose = odom_pose_.to_isometry();
  return o;
}

}  // namespace locd::sim
