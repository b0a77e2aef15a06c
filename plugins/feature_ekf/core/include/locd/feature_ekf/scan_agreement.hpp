// How well a scan fits the map at a pose (beyond the paper; the check of feature_ekf's
// localization state and of its relocalization hypotheses): every k-th beam is cast from the
// laser, placed by the pose, into the map's wall segments, and the beam agrees when its measured
// range is within tolerance + tolerance_per_metre * range of the cast one. Only returns count
// (REP 117: NaN, zero, too-close and max-range readings carry no information and are left out,
// since real lasers miss dark, shiny and glancing surfaces); a return where the map has no wall
// within range_max, or far from the map's wall, disagrees.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "locd/feature_ekf/config.hpp"
#include "locd/sdk/feature_map.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sdk/types.hpp"

namespace locd::feature_ekf {

class ScanAgreement {
 public:
  // Keeps a reference to map: it must outlive this object.
  ScanAgreement(ScanAgreementConfig config, const FeatureMap2D& map);

  // Share of the considered beams that agree; none when fewer than min_beams carry information.
  std::optional<double> agreement(const LaserScan& scan, const Pose2& robot) const;

  // Range from origin along heading to the nearest wall of the map, or +inf when none is hit
  // within max_range: every wall tested (the direct formula).
  double cast(const Eigen::Vector2d& origin, double heading, double max_range) const;

  // cast() for many headings from one origin, with the same results: walls beyond max_range are
  // left out, and each heading tests only the walls whose bearing span (seen from origin, padded
  // by kSpanPadding) holds it.
  std::vector<double> cast_all(const Eigen::Vector2d& origin, const std::vector<double>& headings,
                               double max_range) const;

  // Bearing bins of cast_all (one wall may fill several) and the padding of a wall's span (rad):
  // far above atan2's rounding, far below a beam step.
  static constexpr int kBearingBins = 128;
  static constexpr double kSpanPadding = 1e-9;

  const ScanAgreementConfig& config() const { return config_; }

 private:
  ScanAgreementConfig config_;
  const FeatureMap2D& map_;
};

}  // namespace locd::feature_ekf
