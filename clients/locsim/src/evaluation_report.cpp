#include "locd/sim/evaluation_report.hpp"

#include <nlohmann/json.hpp>

#include <iomanip>
#include <optional>

namespace locd::sim {

namespace {
nlohmann::ordered_json optional_json(const std::optional<double>& v) {
  return v ? nlohmann::ordered_json(*v) : nlohmann::ordered_json(nullptr);
}
}  // namespace

nlohmann::ordered_json consistency_json(const ConsistencySummary& c) {
  return {{"estimates", c.samples},
          {"nees_position_mean", c.nees_position_mean},
          {"nees_position_inside_95", c.position_inside_95_share},
          {"nees_heading_mean", optional_json(c.nees_heading_mean)},
          {"nees_heading_inside_95", optional_json(c.heading_inside_95_share)},
          {"outside_99_share", c.outside_99_share},
          {"heading_outside_99_share", c.heading_samples ? nlohmann::ordered_json(c.heading_outside_99_share)
                                                         : nlohmann::ordered_json(nullptr)},
          {"confidently_wrong_share", c.confidently_wrong_share},
          {"verdict", c.verdict}};
}

nlohmann::ordered_json state_json(const StateSummary& l) {
  const auto share = [&](size_t n) { return l.samples ? static_cast<double>(n) / static_cast<double>(l.samples) : 0.0; };
  nlohmann::ordered_json json = {{"tracking_share", share(l.tracking)},
                                 {"uncertain_share", share(l.uncertain)},
                                 {"lost_share", share(l.lost)},
                                 {"unknown_share", share(l.unknown)},
                                 {"small_error_estimates", l.small_error_samples},
                                 {"false_alarm_share", l.false_alarm_share}};
  if (l.event_s) {
    json["event_s"] = *l.event_s;
    json["detection_delay_s"] = optional_json(l.detection_delay_s);
    json["relocalization_delay_s"] = optional_json(l.relocalization_delay_s);
  }
  return json;
}

void write_consistency_summary(std::ostream& out, const ConsistencySummary& c) {
  if (!c.samples) return;
  const auto percent = [](double share) { return 100.0 * share; };
  const auto flags = out.flags();
  const auto precision = out.precision();
  out << std::fixed << std::setprecision(2);
  out << "  consistency: position NEES mean " << c.nees_position_mean << " (2 if consistent), "
      << percent(c.position_inside_95_share) << " % inside its 95 % bound";
  if (c.nees_heading_mean) {
    out << "; heading NEES mean " << *c.nees_heading_mean << " (1), " << percent(*c.heading_inside_95_share)
        << " % inside";
  } else {
    out << "; no heading variance reported";
  }
  out << "\n  outside the 99 % ellipse " << percent(c.outside_99_share) << " %, confidently wrong "
      << percent(c.confidently_wrong_share) << " % (target <= 1 %: " << (c.confidently_wrong_share <= 0.01 ? "met" : "NOT met")
      << "); covariance " << c.verdict << "\n";
  out.flags(flags);
  out.precision(precision);
}

void write_state_summary(std::ostream& out, const StateSummary& l) {
  if (!l.samples) return;
  const auto flags = out.flags();
  const auto precision = out.precision();
  const auto percent = [&](size_t n) { return 100.0 * static_cast<double>(n) / static_cast<double>(l.samples); };
  out << std::fixed << std::setprecision(1);
  out << "  localization state: tracking " << percent(l.tracking) << " %, uncertain " << percent(l.uncertain)
      << " %, lost " << percent(l.lost) << " %, unknown " << percent(l.unknown) << " %; false alarms "
      << std::setprecision(2) << 100.0 * l.false_alarm_share << " % of " << l.small_error_samples
      << " estimates with a small error\n";
  out.flags(flags);
  out.precision(precision);
}

}  // namespace locd::sim
