#include "locd/sim/state_evaluation.hpp"

namespace locd::sim {

namespace {
bool alarm(LocalizationState s) { return s == LocalizationState::kUncertain || s == LocalizationState::kLost; }
}  // namespace

StateSummary evaluate_states(const std::vector<StateSample>& samples, const StateEvaluationOptions& options) {
  StateSummary out;
  out.samples = samples.size();
  out.event_s = options.event_s;
  for (const StateSample& s : samples) {
    switch (s.state) {
      case LocalizationState::kTracking: ++out.tracking; break;
      case LocalizationState::kUncertain: ++out.uncertain; break;
      case LocalizationState::kLost: ++out.lost; break;
      case LocalizationState::kUnknown: ++out.unknown; break;
    }
    if (s.position_error_m < options.error_threshold_m) {
      ++out.small_error_samples;
      if (alarm(s.state)) ++out.false_alarms;
    }
  }
  if (out.small_error_samples) {
    out.false_alarm_share = static_cast<double>(out.false_alarms) / static_cast<double>(out.small_error_samples);
  }
  if (!options.event_s) return out;
  const double event = *options.event_s;
  for (const StateSample& s : samples) {
    if (s.t >= event && alarm(s.state)) {
      out.detection_delay_s = s.t - event;
      break;
    }
  }
  // The first estimate at or after the event from which the error stays below the threshold.
  std::optional<size_t> good_from;
  for (size_t i = samples.size(); i-- > 0 && samples[i].t >= event;) {
    if (samples[i].position_error_m >= options.error_threshold_m) break;
    good_from = i;
  }
  if (good_from) out.relocalization_delay_s = samples[*good_from].t - event;
  return out;
}

}  // namespace locd::sim
