#include "locd/feature_ekf/scan_agreement.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
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

// Distance from o to the segment a-b.
double distance_to_segment(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d e = b - a;
  const double length_squared = e.squaredNorm();
  const double u = length_squared > 0.0 ? std::clamp((o - a).dot(e) / length_squared, 0.0, 1.0) : 0.0;
  return (a + u * e - o).norm();
}

// An angle in [0, 2 pi).
double wrap_positive(double angle) {
  const double wrapped = std::fmod(angle, 2.0 * M_PI);
  return wrapped < 0.0 ? wrapped + 2.0 * M_PI : wrapped;
}

int bearing_bin(double angle) {
  const int bin = static_cast<int>(wrap_positive(angle) / (2.0 * M_PI) * ScanAgreement::kBearingBins);
  return std::min(bin, ScanAgreement::kBearingBins - 1);
}
}  // namespace

ScanAgreement::ScanAgreement(ScanAgreementConfig config, const FeatureMap2D& map) : config_(config), map_(map) {}

double ScanAgreement::cast(const Eigen::Vector2d& origin, double heading, double max_range) const {
  const Eigen::Vector2d d(std::cos(heading), std::sin(heading));
  double nearest = std::numeric_limits<double>::infinity();
  for (const LineFeature& l : map_.lines) nearest = std::min(nearest, ray_hits_segment(origin, d, l.a, l.b));
  return nearest <= max_range ? nearest : std::numeric_limits<double>::infinity();
}

std::vector<double> ScanAgreement::cast_all(const Eigen::Vector2d& origin, const std::vector<double>& headings,
                                            double max_range) const {
  // A ray from origin that hits a wall (t > 0, 0 <= u <= 1) leaves within the wall's bearing span,
  // the shorter arc between the bearings of its ends; a wall whose nearest point lies beyond
  // max_range cannot give a cast within it.
  struct Span {
    uint32_t line;
    int first_bin, bins;
  };
  std::vector<Span> spans;
  spans.reserve(map_.lines.size());
  std::array<uint32_t, kBearingBins + 1> bin_start{};  // walls per bin, then where each bin starts
  for (size_t k = 0; k < map_.lines.size(); ++k) {
    const LineFeature& l = map_.lines[k];
    if (distance_to_segment(origin, l.a, l.b) > max_range) continue;
    const Eigen::Vector2d to_a = l.a - origin, to_b = l.b - origin;
    double start = std::atan2(to_a.y(), to_a.x());
    double width = std::remainder(std::atan2(to_b.y(), to_b.x()) - start, 2.0 * M_PI);
    if (width < 0.0) {
      start += width;
      width = -width;
    }
    start -= kSpanPadding;
    width += 2.0 * kSpanPadding;
    const Span span{static_cast<uint32_t>(k), bearing_bin(start),
                    std::min(kBearingBins, static_cast<int>(width / (2.0 * M_PI) * kBearingBins) + 2)};
    for (int b = 0; b < span.bins; ++b) ++bin_start[static_cast<size_t>((span.first_bin + b) % kBearingBins) + 1];
    spans.push_back(span);
  }
  for (size_t b = 1; b <= kBearingBins; ++b) bin_start[b] += bin_start[b - 1];
  std::vector<uint32_t> walls(bin_start[kBearingBins]);  // the walls of bin b: [bin_start[b], bin_start[b + 1])
  std::array<uint32_t, kBearingBins> filled{};
  for (const Span& span : spans) {
    for (int b = 0; b < span.bins; ++b) {
      const size_t bin = static_cast<size_t>((span.first_bin + b) % kBearingBins);
      walls[bin_start[bin] + filled[bin]++] = span.line;
    }
  }
  std::vector<double> ranges;
  ranges.reserve(headings.size());
  for (const double heading : headings) {
    const Eigen::Vector2d d(std::cos(heading), std::sin(heading));
    double nearest = std::numeric_limits<double>::infinity();
    const size_t bin = static_cast<size_t>(bearing_bin(heading));
    for (uint32_t w = bin_start[bin]; w < bin_start[bin + 1]; ++w) {
      const LineFeature& l = map_.lines[walls[w]];
      nearest = std::min(nearest, ray_hits_segment(origin, d, l.a, l.b));
    }
    ranges.push_back(nearest <= max_range ? nearest : std::numeric_limits<double>::infinity());
  }
  return ranges;
}

std::optional<double> ScanAgreement::agreement(const LaserScan& scan, const Pose2& robot) const {
  if (scan.ranges.empty()) return std::nullopt;
  const Pose2 laser = robot * Pose2::from_isometry(scan.sensor_pose);
  const Eigen::Vector2d origin(laser.x, laser.y);
  const size_t step = std::max<size_t>(1, scan.ranges.size() / static_cast<size_t>(std::max(config_.beams, 1)));
  std::vector<size_t> beams;
  std::vector<double> headings;
  for (size_t i = 0; i < scan.ranges.size(); i += step) {
    // Only a return is evidence: a NaN, a zero, a too-close or a max-range reading (REP 117) says
    // nothing about the map (real lasers miss dark, shiny and glancing surfaces).
    if (!scan.valid_return(i)) continue;
    beams.push_back(i);
    headings.push_back(laser.theta + scan.angle(i));
  }
  const std::vector<double> cast_ranges = cast_all(origin, headings, scan.range_max);
  const size_t considered = beams.size();
  size_t agreeing = 0;
  for (size_t k = 0; k < considered; ++k) {
    const double measured = scan.ranges[beams[k]];
    if (std::isfinite(cast_ranges[k]) &&
        std::abs(measured - cast_ranges[k]) <= config_.tolerance + config_.tolerance_per_metre * cast_ranges[k]) {
      ++agreeing;
    }
  }
  if (considered < static_cast<size_t>(config_.min_beams)) return std::nullopt;
  return static_cast<double>(agreeing) / static_cast<double>(considered);
}

}  // namespace locd::feature_ekf
