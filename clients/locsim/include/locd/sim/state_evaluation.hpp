// Does a localizer know when it is wrong? Scores the localization state a plugin reports
// (UpdateResult::localization; live: locd/session_status) against its actual error.
//
//   false alarm        the state is uncertain or lost while the position error is below the
//                      threshold (the estimate is good): share of those estimates
//   detection delay    after an event that makes the estimate wrong (a kidnap at time T, or a wrong
//                      start at T = 0): time from T to the first estimate whose state is uncertain
//                      or lost
//   relocalization     time from T to the estimate from which the position error stays below the
//                      threshold to the end of the run (none when it never does)
//
// The state of an estimate is the plugin's last judgement at or before it; unknown before the
// first (a plugin that never judges is unknown throughout: no false alarms, never a detection).
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "locd/sdk/types.hpp"

namespace locd::sim {

struct StateSample {
  double t = 0.0;  // s since the start
  double position_error_m = 0.0;
  LocalizationState state = LocalizationState::kUnknown;
};

struct StateEvaluationOptions {
  double error_threshold_m = 0.2;  // "small" error; and the relocalization threshold
  std::optional<double> event_s;   // kidnap time, or 0 for a wrong start
};

struct StateSummary {
  size_t samples = 0;
  size_t tracking = 0, uncertain = 0, lost = 0, unknown = 0;  // estimates in each state
  size_t small_error_samples = 0;   // position error below the threshold
  size_t false_alarms = 0;          // of those, uncertain or lost
  double false_alarm_share = 0.0;   // false_alarms / small_error_samples (0 when none)
  std::optional<double> event_s;
  std::optional<double> detection_delay_s;       // event -> first uncertain/lost at or after it
  std::optional<double> relocalization_delay_s;  // event -> error below threshold to the end
};

// Samples in time order.
StateSummary evaluate_states(const std::vector<StateSample>& samples, const StateEvaluationOptions& options);

}  // namespace locd::sim
