#include "locd/feature_ekf/scan_agreement.hpp"

#include <cmath>
#include <limits>
#include <vector>

namespace locd::feature_ekf {

namespace {
// The ray o + t d against the segment a + u (b - a): t, or +inf when it misses.
double ray_hits_segment(const Eigen::Vector2d& o, const Eigen::Vector2d& d, const Eigen::Vector2d& a,
                        const Eigen::Vector2d& b) {
  const Eigen::Vector2d e = b - a;
  const double denominator = d.x() * e.y() - d.y() * e.x();
  if (std::abs(denominator) < 1e-12) return std::numeric_limits<double>::infinity();
  const Eigen::Vector2d w = a - o;
  const double t = (w.x() * e.y() - w.y() * e.x()) / denominator;
  const double u = (w.x() * d.y() - w.y() * d.x()) / denominator;
  if (t <= 0.0 || u < 0.0 || u > 1.0) return std::numeric_limits<double>::infinity();
  return t;
}
}  // namespace

ScanAgreement::ScanAgreement(ScanAgreementConfig config, const FeatureMap2D& map) : config_(config), map_(map) {}

double ScanAgreement::cast(const Eigen::Vector2d& origin, double heading, double max_range) const {
  const Eigen::Vector2d d(std::cos(heading), std::sin(heading));
  double nearest = std::numeric_limits<double>::infinity();
  for (const LineFeature& l : map_.lines) nearest = std::min(nearest, ray_hits_segment(origin, d, l.a, l.b));
  return nearest <= max_range ? nearest : std::numeric_limits<double>::infinity();
}

std::optional<double> ScanAgreement::agreement(const LaserScan& scan, const Pose2& robot) const {
  if (scan.ranges.empty()) return std::nullopt;
  const Pose2 laser = robot * Pose2::from_isometry(scan.sensor_pose);
  const Eigen::Vector2d origin(laser.x, laser.y);
  const size_t step = std::max<size_t>(1, scan.ranges.size() / static_cast<size_t>(std::max(config_.beams, 1)));
  size_t considered = 0, agreeing = 0;
  for (size_t i = 0; i < scan.ranges.size(); i += step) {
    // Only a return is evidence: a NaN, a zero, a too-close or a max-range reading (REP 117) says
    // nothing about the map (real lasers miss dark, shiny and glancing surfaces).
    if (!scan.valid_return(i)) continue;
    const double measured = scan.ranges[i];
    const double cast_range = cast(origin, laser.theta + scan.angle(i), scan.range_max);
    ++considered;
    if (std::isfinite(cast_range) &&
        std::abs(measured - cast_range) <= config_.tolerance + config_.tolerance_per_metre * cast_range) {
      ++agreeing;
    }
  }
  if (considered < static_cast<size_t>(config_.min_beams)) return std::nullopt;
  return static_cast<double>(agreeing) / static_cast<double>(considered);
}

}  // namespace locd::feature_ekf
