#include "locd/sim/montecarlo.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>

#include "locd/sim/report.hpp"

namespace locd::sim {

namespace {

std::optional<double> median_of(std::vector<double> v) {
  if (v.empty()) return std::nullopt;
  return percentile(std::move(v), 50);
}

std::optional<double> max_of(const std::vector<double>& v) {
  if (v.empty()) return std::nullopt;
  return *std::max_element(v.begin(), v.end());
}

nlohmann::ordered_json optional_json(const std::optional<double>& v) {
  return v ? nlohmann::ordered_json(*v) : nlohmann::ordered_json(nullptr);
}

}  // namespace

MonteCarloSummary pool_runs(const std::string& scenario, const std::string& plugin, uint64_t first_seed,
                            const EvaluationSpec& evaluation, const std::vector<RunResult>& runs) {
  MonteCarloSummary out;
  out.scenario = scenario;
  out.plugin = plugin;
  out.first_seed = first_seed;
  out.evaluation = evaluation;
  std::vector<ConsistencySample> pooled;
  std::vector<double> rmse, detection_delays, relocalization_delays;
  for (const RunResult& r : runs) {
    SeedRun run;
    run.seed = r.seed;
    run.rmse_m = r.summary.rmse_m;
    run.max_error_m = r.summary.max_error_m;
    run.consistency = r.summary.consistency;
    run.localization = r.summary.localization;
    run.event = r.event;
    run.rejected = r.rejected;
    out.runs.push_back(run);
    for (const ScoredEstimate& e : r.estimates) pooled.push_back({e.nees, e.state});
    rmse.push_back(r.summary.rmse_m);
    out.small_error_estimates += r.summary.localization.small_error_samples;
    out.false_alarms += r.summary.localization.false_alarms;
    if (!r.event) continue;
    out.with_event = true;
    const StateSummary& l = r.summary.localization;
    if (l.detection_delay_s && *l.detection_delay_s <= evaluation.detection_deadline_s) ++out.detected;
    if (l.detection_delay_s) detection_delays.push_back(*l.detection_delay_s);
    if (l.relocalization_delay_s && *l.relocalization_delay_s <= evaluation.relocalization_deadline_s) ++out.relocalized;
    if (l.relocalization_delay_s) relocalization_delays.push_back(*l.relocalization_delay_s);
  }
  out.consistency = summarize_consistency(pooled);
  if (out.small_error_estimates) {
    out.false_alarm_share = static_cast<double>(out.false_alarms) / static_cast<double>(out.small_error_estimates);
  }
  if (!rmse.empty()) {
    out.rmse_median_m = percentile(rmse, 50);
    out.rmse_max_m = *std::max_element(rmse.begin(), rmse.end());
  }
  out.detection_delay_median_s = median_of(detection_delays);
  out.detection_delay_max_s = max_of(detection_delays);
  out.relocalization_delay_median_s = median_of(relocalization_delays);
  out.relocalization_delay_max_s = max_of(relocalization_delays);
  return out;
}

MonteCarloSummary run_seeds(const Scenario& scenario, const OfflineRunOptions& options, int runs, uint64_t first_seed,
                            std::ostream* progress) {
  std::vector<RunResult> results;
  for (int i = 0; i < runs; ++i) {
    OfflineRunOptions o = options;
    o.seed = first_seed + static_cast<uint64_t>(i);
    results.push_back(run_offline(scenario, o));
    const RunResult& r = results.back();
    if (progress) {
      *progress << "seed " << r.seed << ": rmse " << std::setprecision(3) << r.summary.rmse_m << " m, confidently wrong "
                << 100.0 * r.summary.consistency.confidently_wrong_share << " %";
      if (r.event) {
        const StateSummary& l = r.summary.localization;
        const auto seconds = [](const std::optional<double>& v) {
          if (!v) return std::string("never");
          char text[32];
          std::snprintf(text, sizeof(text), "%.2f s", *v);
          return std::string(text);
        };
        *progress << ", " << r.event->kind << " " << r.event->distance_m << " m: detected "
                  << seconds(l.detection_delay_s) << ", relocalized " << seconds(l.relocalization_delay_s);
      }
      *progress << std::endl;
    }
  }
  return pool_runs(scenario.name, scenario.localizer.plugin, first_seed, scenario.evaluation, results);
}

void write_montecarlo_json(std::ostream& out, const MonteCarloSummary& m) {
  nlohmann::ordered_json runs = nlohmann::ordered_json::array();
  for (const SeedRun& r : m.runs) {
    runs.push_back({{"seed", r.seed},
                    {"rmse_m", r.rmse_m},
                    {"max_error_m", r.max_error_m},
                    {"rejected", r.rejected},
                    {"consistency", consistency_json(r.consistency)},
                    {"localization", localization_json(r.localization, r.event)}});
  }
  const size_t n = m.runs.size();
  const auto share = [n](size_t k) { return n ? static_cast<double>(k) / static_cast<double>(n) : 0.0; };
  nlohmann::ordered_json pooled = {{"rmse_median_m", m.rmse_median_m},
                                   {"rmse_max_m", m.rmse_max_m},
                                   {"consistency", consistency_json(m.consistency)},
                                   {"small_error_estimates", m.small_error_estimates},
                                   {"false_alarm_share", m.false_alarm_share}};
  if (m.with_event) {
    pooled["detection_deadline_s"] = m.evaluation.detection_deadline_s;
    pooled["detected_runs"] = m.detected;
    pooled["detected_share"] = share(m.detected);
    pooled["detection_delay_median_s"] = optional_json(m.detection_delay_median_s);
    pooled["detection_delay_max_s"] = optional_json(m.detection_delay_max_s);
    pooled["relocalization_deadline_s"] = m.evaluation.relocalization_deadline_s;
    pooled["relocalized_runs"] = m.relocalized;
    pooled["relocalized_share"] = share(m.relocalized);
    pooled["relocalization_delay_median_s"] = optional_json(m.relocalization_delay_median_s);
    pooled["relocalization_delay_max_s"] = optional_json(m.relocalization_delay_max_s);
  }
  const nlohmann::ordered_json json = {{"scenario", m.scenario}, {"plugin", m.plugin},  {"runs", n},
                                       {"first_seed", m.first_seed}, {"pooled", pooled}, {"per_run", runs}};
  out << json.dump(2) << "\n";
}

void write_montecarlo_summary(std::ostream& out, const MonteCarloSummary& m) {
  const size_t n = m.runs.size();
  out << std::fixed << std::setprecision(3);
  out << "scenario " << m.scenario << ", plugin " << m.plugin << ": " << n << " runs, seeds " << m.first_seed << "-"
      << m.first_seed + n - 1 << "\n";
  out << "  rmse: median " << m.rmse_median_m << " m, max " << m.rmse_max_m << " m\n";
  write_consistency_summary(out, m.consistency);
  out << std::setprecision(2) << "  false alarms: " << 100.0 * m.false_alarm_share << " % of " << m.small_error_estimates
      << " estimates with an error below " << m.evaluation.convergence_threshold_m << " m (target <= 1 %: "
      << (m.false_alarm_share <= 0.01 ? "met" : "NOT met") << ")\n";
  if (m.with_event && n) {
    const auto percent = [n](size_t k) { return 100.0 * static_cast<double>(k) / static_cast<double>(n); };
    out << "  uncertain or lost within " << m.evaluation.detection_deadline_s << " s: " << m.detected << " of " << n
        << " runs (" << percent(m.detected) << " %; target >= 95 %)";
    if (m.detection_delay_median_s) {
      out << ", delay median " << *m.detection_delay_median_s << " s, max " << *m.detection_delay_max_s << " s";
    }
    out << "\n  relocalized within " << m.evaluation.relocalization_deadline_s << " s: " << m.relocalized << " of " << n
        << " runs (" << percent(m.relocalized) << " %)";
    if (m.relocalization_delay_median_s) {
      out << ", delay median " << *m.relocalization_delay_median_s << " s, max " << *m.relocalization_delay_max_s << " s";
    }
    out << "\n";
  }
  out << std::defaultfloat;
}

}  // namespace locd::sim
