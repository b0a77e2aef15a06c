// How every locsim command reports consistency (consistency.hpp) and the localization state
// (state_evaluation.hpp): the JSON objects and the summary lines, one form for every scenario kind.
//
//   "consistency": {estimates, nees_position_mean, nees_position_inside_95, nees_heading_mean,
//                   nees_heading_inside_95, outside_99_share, heading_outside_99_share,
//                   confidently_wrong_share, verdict}
//   "localization": {tracking_share, uncertain_share, lost_share, unknown_share,
//                    small_error_estimates, false_alarm_share, and with an event: event_s,
//                    detection_delay_s, relocalization_delay_s}
//
// A number that is not finite (a mean NEES over a singular covariance) is written as null.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <ostream>

#include "locd/sim/consistency.hpp"
#include "locd/sim/state_evaluation.hpp"

namespace locd::sim {

nlohmann::ordered_json consistency_json(const ConsistencySummary& consistency);
nlohmann::ordered_json state_json(const StateSummary& localization);

// "  consistency: position NEES mean ..." (two lines); nothing without estimates.
void write_consistency_summary(std::ostream& out, const ConsistencySummary& consistency);
// "  localization state: tracking ... %; false alarms ..." (one line); nothing without estimates.
void write_state_summary(std::ostream& out, const StateSummary& localization);

}  // namespace locd::sim
