// Data association of extracted features with the map (sec. 2.3.3 - 2.3.4): every candidate map
// feature's measurement is predicted from the predicted pose (eq. 8), its innovation gated by
// the squared Mahalanobis distance against the chi-square quantile for the measurement's
// dimension (eq. 9, 12), and the nearest candidate inside the gate is taken.
// Candidates beyond the paper: only map features within range, and for lines only map segments
// that the measured segment overlaps when projected onto them. Measured edges (occluding ends)
// may match map edges and map corners (a convex corner seen with one face hidden is one).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "locd/feature_ekf/config.hpp"
#include "locd/feature_ekf/laser_feature_extractor.hpp"
#include "locd/sdk/feature_map.hpp"
#include "locd/sdk/gaussian.hpp"

namespace locd::feature_ekf {

enum class FeatureKind { kLine = 0, kCorner = 1, kEdge = 2 };
const char* feature_kind_name(FeatureKind kind);  // "line", "corner", "edge"

// v^T S^-1 v for a 2-vector, fixed size (no allocation); +inf when S is not positive definite.
// Same value as locd::mahalanobis2, which works on dynamic sizes.
double squared_mahalanobis(const Eigen::Vector2d& innovation, const Eigen::Matrix2d& S);

struct Association {
  FeatureKind measured_kind = FeatureKind::kLine;
  size_t measurement = 0;           // index in the extracted list of its kind
  FeatureKind map_kind = FeatureKind::kLine;
  int map_index = -1;               // index in the map's list of map_kind; -1 = none inside the gate
  uint32_t candidates_in_gate = 0;
  double mahalanobis2 = 0.0;        // of the chosen candidate (or the nearest candidate when none passed)
  bool associated() const { return map_index >= 0; }
};

class NearestNeighborAssociation {
 public:
  explicit NearestNeighborAssociation(AssociationConfig config = {});

  // One record per extracted feature (lines, then corners, then edges), associated or not.
  std::vector<Association> associate(const ExtractedFeatures& features, const FeatureMap2D& map,
                                     const Eigen::Vector3d& pose, const Eigen::Matrix3d& covariance) const;

  // True when the measured segment (robot frame), placed by `pose`, overlaps the map segment.
  bool line_visible(const ExtractedLine& measured, const LineFeature& map_line, const Eigen::Vector3d& pose) const;

  const ChiSquareGate& gate() const { return gate_; }
  const AssociationConfig& config() const { return config_; }

 private:
  AssociationConfig config_;
  ChiSquareGate gate_;
};

}  // namespace locd::feature_ekf
