#include "locd/feature_ekf/nearest_neighbor_association.hpp"

#include <algorithm>
#include <limits>

#include "locd/feature_ekf/feature_measurement_model.hpp"
#include "locd/sdk/geometry.hpp"

namespace locd::feature_ekf {

const char* feature_kind_name(FeatureKind kind) {
  switch (kind) {
    case FeatureKind::kLine: return "line";
    case FeatureKind::kCorner: return "corner";
    case FeatureKind::kEdge: return "edge";
  }
  return "unknown";
}

double squared_mahalanobis(const Eigen::Vector2d& innovation, const Eigen::Matrix2d& S) {
  const Eigen::LLT<Eigen::Matrix2d> llt(S);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  return llt.matrixL().solve(innovation).squaredNorm();
}

namespace {

double distance_to_segment(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + t * ab - p).norm();
}

// Keeps the candidate nearest in Mahalanobis distance among those inside the gate; while none
// is inside, remembers the nearest distance seen (for the report).
void consider(Association& best, double d2, bool inside, FeatureKind map_kind, size_t index) {
  if (inside) {
    ++best.candidates_in_gate;
    if (best.map_index < 0 || d2 < best.mahalanobis2) {
      best.map_index = static_cast<int>(index);
      best.map_kind = map_kind;
      best.mahalanobis2 = d2;
    }
  } else if (best.map_index < 0 && d2 < best.mahalanobis2) {
    best.mahalanobis2 = d2;
  }
}

void nearest_point(const ExtractedPoint& measured, const std::vector<PointFeature>& map_points,
                   FeatureKind map_kind, const Eigen::Vector3d& pose, const Eigen::Matrix3d& P,
                   double max_range, const ChiSquareGate& gate, Association& best) {
  const Eigen::Vector2d robot(pose.x(), pose.y());
  for (size_t j = 0; j < map_points.size(); ++j) {
    if ((map_points[j].position - robot).norm() > max_range) continue;
    MeasurementJacobian H;
    const Measurement2 predicted = FeatureMeasurementModel::predict_point(map_points[j].position, pose, &H);
    const Measurement2 v = FeatureMeasurementModel::innovation(measured.z, predicted);
    const Eigen::Matrix2d S = H * P * H.transpose() + measured.covariance;
    const double d2 = squared_mahalanobis(v, S);
    consider(best, d2, gate.accepts(d2, 2), map_kind, j);
  }
}

}  // namespace

NearestNeighborAssociation::NearestNeighborAssociation(AssociationConfig config)
    : config_(config), gate_(config.gate_probability) {}

bool NearestNeighborAssociation::line_visible(const ExtractedLine& measured, const LineFeature& map_line,
                                              const Eigen::Vector3d& pose) const {
  const Pose2 robot = Pose2::from_vector(pose);
  if (distance_to_segment({pose.x(), pose.y()}, map_line.a, map_line.b) > config_.max_range) return false;
  const Eigen::Vector2d axis = map_line.b - map_line.a;
  const double length = axis.norm();
  const Eigen::Vector2d u = axis / length;
  const double t_start = (robot.transform(measured.start) - map_line.a).dot(u);
  const double t_end = (robot.transform(measured.end) - map_line.a).dot(u);
  const double lo = std::min(t_start, t_end), hi = std::max(t_start, t_end);
  return hi >= -config_.line_overlap_margin && lo <= length + config_.line_overlap_margin;
}

std::vector<Association> NearestNeighborAssociation::associate(const ExtractedFeatures& features,
                                                               const FeatureMap2D& map,
                                                               const Eigen::Vector3d& pose,
                                                               const Eigen::Matrix3d& P) const {
  std::vector<Association> result;
  result.reserve(features.lines.size() + features.corners.size() + features.edges.size());
  const double none = std::numeric_limits<double>::infinity();

  for (size_t i = 0; i < features.lines.size(); ++i) {
    const ExtractedLine& measured = features.lines[i];
    Association best{FeatureKind::kLine, i, FeatureKind::kLine, -1, 0, none};
    for (size_t j = 0; j < map.lines.size(); ++j) {
      const LineFeature& map_line = map.lines[j];
      if (!line_visible(measured, map_line, pose)) continue;
      MeasurementJacobian H;
      const Measurement2 predicted = FeatureMeasurementModel::predict_line(map_line.rho(), map_line.alpha(), pose, &H);
      const Measurement2 v = FeatureMeasurementModel::innovation(measured.z, predicted);
      const Eigen::Matrix2d S = H * P * H.transpose() + measured.covariance;
      const double d2 = squared_mahalanobis(v, S);
      consider(best, d2, gate_.accepts(d2, 2), FeatureKind::kLine, j);
    }
    result.push_back(best);
  }
  for (size_t i = 0; i < features.corners.size(); ++i) {
    Association best{FeatureKind::kCorner, i, FeatureKind::kCorner, -1, 0, none};
    nearest_point(features.corners[i], map.corners, FeatureKind::kCorner, pose, P, config_.max_range, gate_, best);
    result.push_back(best);
  }
  for (size_t i = 0; i < features.edges.size(); ++i) {
    Association best{FeatureKind::kEdge, i, FeatureKind::kEdge, -1, 0, none};
    nearest_point(features.edges[i], map.edges, FeatureKind::kEdge, pose, P, config_.max_range, gate_, best);
    nearest_point(features.edges[i], map.corners, FeatureKind::kCorner, pose, P, config_.max_range, gate_, best);
    result.push_back(best);
  }
  return result;
}

}  // namespace locd::feature_ekf
