#include "locd/sim/consistency.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>

#include "locd/sdk/gaussian.hpp"

namespace locd::sim {

Nees nees(const Pose2& estimate, const Pose2& truth, const Eigen::Matrix3d& covariance) {
  Nees out;
  const Eigen::Vector2d e(estimate.x - truth.x, estimate.y - truth.y);
  const Eigen::Matrix2d P = 0.5 * (covariance.topLeftCorner<2, 2>() + covariance.topLeftCorner<2, 2>().transpose());
  const Eigen::LLT<Eigen::Matrix2d> llt(P);
  if (llt.info() == Eigen::Success && P.allFinite()) {
    out.position = llt.matrixL().solve(e).squaredNorm();
  } else {
    out.position = e.isZero(0.0) ? 0.0 : std::numeric_limits<double>::infinity();
  }
  const double heading_variance = covariance(2, 2);
  if (heading_variance > 0.0 && std::isfinite(heading_variance)) {
    const double e_yaw = normalize_angle(estimate.theta - truth.theta);
    out.heading = e_yaw * e_yaw / heading_variance;
  }
  return out;
}

const ConsistencyBounds& ConsistencyBounds::get() {
  static const ConsistencyBounds bounds{chi_square_quantile(0.95, 2), chi_square_quantile(0.99, 2),
                                        chi_square_quantile(0.95, 1), chi_square_quantile(0.99, 1)};
  return bounds;
}

ConsistencySummary summarize_consistency(const std::vector<ConsistencySample>& samples) {
  ConsistencySummary out;
  out.samples = samples.size();
  if (samples.empty()) return out;
  const ConsistencyBounds& b = ConsistencyBounds::get();
  double position_sum = 0.0, heading_sum = 0.0;
  size_t position_inside = 0, heading_inside = 0, outside = 0, heading_outside = 0, confidently_wrong = 0;
  for (const ConsistencySample& s : samples) {
    position_sum += s.nees.position;
    if (s.nees.position <= b.position_95) ++position_inside;
    if (s.nees.position > b.position_99) {
      ++outside;
      if (s.state == LocalizationState::kTracking || s.state == LocalizationState::kUnknown) ++confidently_wrong;
    }
    if (s.nees.heading) {
      ++out.heading_samples;
      heading_sum += *s.nees.heading;
      if (*s.nees.heading <= b.heading_95) ++heading_inside;
      if (*s.nees.heading > b.heading_99) ++heading_outside;
    }
  }
  const double n = static_cast<double>(samples.size());
  out.nees_position_mean = position_sum / n;
  out.position_inside_95_share = static_cast<double>(position_inside) / n;
  out.outside_99_share = static_cast<double>(outside) / n;
  out.confidently_wrong_share = static_cast<double>(confidently_wrong) / n;
  if (out.heading_samples) {
    const double h = static_cast<double>(out.heading_samples);
    out.nees_heading_mean = heading_sum / h;
    out.heading_inside_95_share = static_cast<double>(heading_inside) / h;
    out.heading_outside_99_share = static_cast<double>(heading_outside) / h;
  }
  if (out.position_inside_95_share < 0.90) {
    out.verdict = "overconfident";
  } else if (out.nees_position_mean < 1.0) {
    out.verdict = "conservative";
  } else {
    out.verdict = "consistent";
  }
  return out;
}

}  // namespace locd::sim
