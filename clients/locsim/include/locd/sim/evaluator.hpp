// Scores a trajectory of estimates against the truth: position and heading errors, their
// percentiles, update times and (live) latencies, when the estimate converged, whether its
// covariance can be trusted (consistency.hpp) and whether the plugin's localization state told
// the truth (state_evaluation.hpp).
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/types.hpp"
#include "locd/sim/consistency.hpp"
#include "locd/sim/state_evaluation.hpp"

namespace locd::sim {

// The p-th percentile (0..100) with linear interpolation between closest ranks (numpy's
// default); NaN for an empty list.
double percentile(std::vector<double> values, double p);

struct ScoredEstimate {
  double t = 0.0;  // s since the start
  Pose2 estimate, truth;
  double position_error_m = 0.0;
  double heading_error_rad = 0.0;  // |wrapped difference|
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // reported, over (x, y, yaw)
  Nees nees;
  LocalizationState state = LocalizationState::kUnknown;  // the plugin's last judgement
  double update_ms = 0.0;
  std::optional<double> latency_ms;
};

struct EvaluationSummary {
  size_t updates = 0;
  double mean_error_m = 0, rmse_m = 0, p95_error_m = 0, max_error_m = 0, final_error_m = 0;
  double mean_heading_error_deg = 0;
  double update_ms_p50 = 0, update_ms_p99 = 0;
  // Converged: the error stays below the threshold from convergence_time_s to the end.
  bool converged = false;
  std::optional<double> convergence_time_s;
  std::optional<double> latency_ms_p50, latency_ms_p99;    // live only
  std::optional<double> overhead_ms_p50, overhead_ms_p99;  // latency - update_ms, live only
  std::optional<double> max_pose_gap_ms;  // live only: longest wall-clock wait between two poses received
  ConsistencySummary consistency;
  StateSummary localization;
};

class TrajectoryEvaluator {
 public:
  // event_s: when the estimate was made wrong on purpose (a kidnap; 0 for a wrong start), for the
  // detection and relocalization delays. The convergence threshold is also the error below
  // which a state other than tracking is a false alarm.
  explicit TrajectoryEvaluator(double convergence_threshold_m = 0.2, std::optional<double> event_s = std::nullopt);

  // Estimates in time order, each with the state the plugin reported at that time.
  const ScoredEstimate& add(double t, const PoseEstimate& estimate, const Pose2& truth, LocalizationState state,
                            double update_ms, std::optional<double> latency_ms = std::nullopt);
  EvaluationSummary summary() const;
  const std::vector<ScoredEstimate>& estimates() const { return estimates_; }
  double convergence_threshold() const { return threshold_; }

 private:
  double threshold_;
  std::optional<double> event_s_;
  std::vector<ScoredEstimate> estimates_;
};

}  // namespace locd::sim
