#include "locd/sim/evaluator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace locd::sim {

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const double rank = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(values.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(rank));
  const size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (rank - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

TrajectoryEvaluator::TrajectoryEvaluator(double convergence_threshold_m, std::optional<double> event_s)
    : threshold_(convergence_threshold_m), event_s_(event_s) {
  if (!(convergence_threshold_m > 0)) throw std::invalid_argument("convergence threshold must be positive");
}

const ScoredEstimate& TrajectoryEvaluator::add(double t, const PoseEstimate& estimate, const Pose2& truth,
                                               LocalizationState state, double update_ms,
                                               std::optional<double> latency_ms) {
  ScoredEstimate s;
  s.t = t;
  s.estimate = Pose2::from_isometry(estimate.pose);
  s.truth = truth;
  s.position_error_m = std::hypot(s.estimate.x - truth.x, s.estimate.y - truth.y);
  s.heading_error_rad = std::abs(normalize_angle(s.estimate.theta - truth.theta));
  s.covariance = planar_covariance(estimate.covariance);
  s.nees = nees(s.estimate, truth, s.covariance);
  s.state = state;
  s.update_ms = update_ms;
  s.latency_ms = latency_ms;
  estimates_.push_back(s);
  return estimates_.back();
}

EvaluationSummary TrajectoryEvaluator::summary() const {
  EvaluationSummary out;
  out.updates = estimates_.size();
  out.localization.event_s = event_s_;
  if (estimates_.empty()) return out;
  std::vector<double> errors, update_ms, latency_ms, overhead_ms;
  std::vector<ConsistencySample> consistency;
  std::vector<StateSample> states;
  double sum = 0, sum2 = 0, heading = 0;
  for (const auto& e : estimates_) {
    consistency.push_back({e.nees, e.state});
    states.push_back({e.t, e.position_error_m, e.state});
    errors.push_back(e.position_error_m);
    update_ms.push_back(e.update_ms);
    sum += e.position_error_m;
    sum2 += e.position_error_m * e.position_error_m;
    heading += e.heading_error_rad;
    if (e.latency_ms) {
      latency_ms.push_back(*e.latency_ms);
      overhead_ms.push_back(*e.latency_ms - e.update_ms);
    }
  }
  const double n = static_cast<double>(estimates_.size());
  out.mean_error_m = sum / n;
  out.rmse_m = std::sqrt(sum2 / n);
  out.p95_error_m = percentile(errors, 95);
  out.max_error_m = *std::max_element(errors.begin(), errors.end());
  out.final_error_m = errors.back();
  out.mean_heading_error_deg = heading / n * 180.0 / M_PI;
  out.update_ms_p50 = percentile(update_ms, 50);
  out.update_ms_p99 = percentile(update_ms, 99);
  if (!latency_ms.empty()) {
    out.latency_ms_p50 = percentile(latency_ms, 50);
    out.latency_ms_p99 = percentile(latency_ms, 99);
    out.overhead_ms_p50 = percentile(overhead_ms, 50);
    out.overhead_ms_p99 = percentile(overhead_ms, 99);
  }
  // The first estimate after the last one at or above the threshold.
  size_t first_good = 0;
  for (size_t i = estimates_.size(); i-- > 0;) {
    if (estimates_[i].position_error_m >= threshold_) {
      first_good = i + 1;
      break;
    }
  }
  out.converged = first_good < estimates_.size();
  out.consistency = summarize_consistency(consistency);
  out.localization = evaluate_states(states, {threshold_, event_s_});
  if (out.converged) out.convergence_time_s = estimates_[first_good].t;
  return out;
}

}  // namespace locd::sim
