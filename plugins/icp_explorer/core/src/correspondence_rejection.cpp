#include "locd/icp_explorer/correspondence_rejection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace {
// sqrt(x^2 + y^2) without std::hypot's overflow care (coordinates are metres).
inline double planar_norm(double x, double y) { return std::sqrt(x * x + y * y); }
}  // namespace

namespace locd::icp_explorer {

const char* rejection_name(Rejection r) {
  switch (r) {
    case Rejection::kAccepted: return "accepted";
    case Rejection::kIntensity: return "intensity";
    case Rejection::kOverlap: return "overlap";
    case Rejection::kErrorLength: return "error_length";
    case Rejection::kErrorDirection: return "error_direction";
  }
  return "unknown";
}

CorrespondenceRejector::CorrespondenceRejector(const RejectionRules& rules, const OdometryErrorBound& bound,
                                               const Eigen::Isometry3d& T_map_base_predicted,
                                               const Eigen::Isometry3d& sensor_in_base)
    : rules_(rules),
      bound_(bound),
      sensor_pose_(sensor_in_base),
      T_map_base_(T_map_base_predicted),
      T_base_map_(T_map_base_predicted.inverse()),
      sensor_in_map_((T_map_base_predicted * sensor_in_base).translation()),
      sensor_in_base_(sensor_in_base.translation()) {
  translation_bound_ = std::sqrt(bound.forward * bound.forward + bound.lateral * bound.lateral +
                                 bound.vertical * bound.vertical);
  const double radius = rules.max_range + translation_bound_ + bound.margin;
  overlap_radius2_ = radius * radius;
  chord_per_metre_ = 2.0 * std::sin(std::min(bound.yaw, M_PI) / 2.0);
  sin_tilt_ = std::sin(bound.tilt);
}

CorrespondenceRejector CorrespondenceRejector::widened(double extra) const {
  OdometryErrorBound bound = bound_;
  bound.margin += extra;
  return CorrespondenceRejector(rules_, bound, T_map_base_, sensor_pose_);
}

bool CorrespondenceRejector::intensity_consistent(float point_intensity, float model_intensity) const {
  if (!std::isfinite(point_intensity) || !std::isfinite(model_intensity)) return true;
  return std::abs(point_intensity - model_intensity) <= rules_.intensity_threshold;
}

bool CorrespondenceRejector::in_overlap_region(const Eigen::Vector3d& model_point) const {
  return (model_point - sensor_in_map_).squaredNorm() <= overlap_radius2_;
}

double CorrespondenceRejector::max_error_length(const Eigen::Vector3d& p) const {
  const double r_xy = planar_norm(p.x(), p.y());
  return translation_bound_ + chord_per_metre_ * r_xy + sin_tilt_ * p.norm() + bound_.margin;
}

bool CorrespondenceRejector::error_direction_possible(const Eigen::Vector3d& p, const Eigen::Vector3d& q) const {
  // Error in the predicted base frame: q_base - p.
  const Eigen::Vector3d e = T_base_map_ * q - p;
  const double vertical = bound_.vertical + sin_tilt_ * planar_norm(p.x(), p.y()) + bound_.margin;
  if (std::abs(e.z()) > vertical) return false;
  // Horizontal: e_xy = box translation + s * tangent, |s| <= chord(yaw) * r_xy, tangent = (-p_y, p_x) / r_xy.
  const double r_xy = planar_norm(p.x(), p.y());
  const double half_x = bound_.forward + bound_.margin;
  const double half_y = bound_.lateral + bound_.margin;
  double s_low = -chord_per_metre_ * r_xy, s_high = chord_per_metre_ * r_xy;
  if (r_xy < 1e-9) return std::abs(e.x()) <= half_x && std::abs(e.y()) <= half_y;
  const Eigen::Vector2d tangent(-p.y() / r_xy, p.x() / r_xy);
  const double half[2] = {half_x, half_y};
  for (int a = 0; a < 2; ++a) {
    const double t = tangent[a];
    if (std::abs(t) < 1e-12) {
      if (std::abs(e[a]) > half[a]) return false;
      continue;
    }
    double lo = (e[a] - half[a]) / t, hi = (e[a] + half[a]) / t;
    if (lo > hi) std::swap(lo, hi);
    s_low = std::max(s_low, lo);
    s_high = std::min(s_high, hi);
    if (s_low > s_high) return false;
  }
  return true;
}

Rejection CorrespondenceRejector::check(const Eigen::Vector3d& p, float point_intensity, const Eigen::Vector3d& q,
                                        float model_intensity) const {
  if (rules_.intensity && !intensity_consistent(point_intensity, model_intensity)) return Rejection::kIntensity;
  if (rules_.overlap && !in_overlap_region(q)) return Rejection::kOverlap;
  if (rules_.error_length && (q - T_map_base_ * p).norm() > max_error_length(p)) return Rejection::kErrorLength;
  if (rules_.error_direction && !error_direction_possible(p, q)) return Rejection::kErrorDirection;
  return Rejection::kAccepted;
}

}  // namespace locd::icp_explorer
