#include "locd/grid_mcl/motion_models.hpp"

#include <algorithm>
#include <cmath>

namespace locd::grid_mcl {

namespace {

// Wraps a heading that moved by less than a turn since it was last wrapped.
double wrap(double a) { return a > M_PI ? a - 2.0 * M_PI : a < -M_PI ? a + 2.0 * M_PI : a; }

struct DifferentialIncrement {
  double rot1 = 0.0, trans = 0.0, rot2 = 0.0;
  double rot1_noise = 0.0, rot2_noise = 0.0;  // smallest angle to forward or backward
};

DifferentialIncrement differential_increment(const Pose2& before, const Pose2& after) {
  DifferentialIncrement d;
  const double dx = after.x - before.x, dy = after.y - before.y;
  d.trans = std::hypot(dx, dy);
  d.rot1 = d.trans < 0.01 ? 0.0 : normalize_angle(std::atan2(dy, dx) - before.theta);
  d.rot2 = normalize_angle(normalize_angle(after.theta - before.theta) - d.rot1);
  const auto undirected = [](double a) { return std::min(std::abs(a), std::abs(normalize_angle(a - M_PI))); };
  d.rot1_noise = undirected(d.rot1);
  d.rot2_noise = undirected(d.rot2);
  return d;
}

}  // namespace

MotionModel::MotionModel(MotionModelType type, const MotionNoise& noise) : type_(type), noise_(noise) {}

Eigen::Vector3d MotionModel::stddev(const Pose2& before, const Pose2& after) const {
  const MotionNoise& a = noise_;
  if (type_ == MotionModelType::kDifferential) {
    const DifferentialIncrement d = differential_increment(before, after);
    const double t2 = d.trans * d.trans, r1 = d.rot1_noise * d.rot1_noise, r2 = d.rot2_noise * d.rot2_noise;
    return {std::sqrt(a.alpha1 * r1 + a.alpha2 * t2), std::sqrt(a.alpha3 * t2 + a.alpha4 * (r1 + r2)),
            std::sqrt(a.alpha1 * r2 + a.alpha2 * t2)};
  }
  const double trans = std::hypot(after.x - before.x, after.y - before.y);
  const double rot = normalize_angle(after.theta - before.theta);
  const double t2 = trans * trans, r2 = rot * rot;
  return {std::sqrt(a.alpha3 * t2 + a.alpha1 * r2), std::sqrt(a.alpha4 * t2 + a.alpha2 * r2),
          std::sqrt(a.alpha1 * r2 + a.alpha5 * t2)};
}

void MotionModel::sample(std::vector<PoseParticle>& particles, const Pose2& before, const Pose2& after,
                         std::mt19937_64& rng) const {
  const ZigguratNormal& normal = normal_;
  const Eigen::Vector3d s = stddev(before, after);
  if (type_ == MotionModelType::kDifferential) {
    const DifferentialIncrement d = differential_increment(before, after);
    for (PoseParticle& p : particles) {
      const double rot1 = d.rot1 - s[0] * normal(rng);
      const double trans = d.trans - s[1] * normal(rng);
      const double rot2 = d.rot2 - s[2] * normal(rng);
      const double heading = p.pose.theta + rot1;
      p.pose.x += trans * std::cos(heading);
      p.pose.y += trans * std::sin(heading);
      p.pose.theta = wrap(wrap(p.pose.theta + rot1 + rot2));
    }
    return;
  }
  const double dx = after.x - before.x, dy = after.y - before.y;
  const double trans = std::hypot(dx, dy);
  const double rot = normalize_angle(after.theta - before.theta);
  // The translation's bearing relative to the odometry heading.
  const double bearing = trans > 0.0 ? normalize_angle(std::atan2(dy, dx) - before.theta) : 0.0;
  for (PoseParticle& p : particles) {
    const double heading = p.pose.theta + bearing;
    const double c = std::cos(heading), sn = std::sin(heading);
    const double t = trans + s[0] * normal(rng);
    const double r = rot + s[1] * normal(rng);
    const double strafe = s[2] * normal(rng);
    p.pose.x += t * c + strafe * sn;
    p.pose.y += t * sn - strafe * c;
    p.pose.theta = wrap(wrap(p.pose.theta + r));
  }
}

}  // namespace locd::grid_mcl
