// `locsim montecarlo SCENARIO.yaml --runs N [--seed S]` for segment-world scenarios: the scenario
// offline through its plugin with seeds S, S+1, ..., S+N-1 (the sensors' noise, the kidnap's
// destination and the wrong start differ per seed), every run scored as `locsim run` scores it,
// then pooled: the targets are rates over runs (a kidnap reported within 5 s in >= 95 % of
// runs) and shares over all estimates (confidently wrong <= 1 %, false alarms <= 1 %).
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "locd/sim/consistency.hpp"
#include "locd/sim/offline_runner.hpp"
#include "locd/sim/scenario.hpp"

namespace locd::sim {

struct SeedRun {
  uint64_t seed = 0;
  double rmse_m = 0.0, max_error_m = 0.0;
  ConsistencySummary consistency;
  StateSummary localization;
  std::optional<SimulatedEvent> event;
  size_t rejected = 0;
};

struct MonteCarloSummary {
  std::string scenario, plugin;
  uint64_t first_seed = 1;
  EvaluationSpec evaluation;
  std::vector<SeedRun> runs;
  // Pooled over every estimate of every run.
  ConsistencySummary consistency;
  size_t small_error_estimates = 0, false_alarms = 0;
  double false_alarm_share = 0.0;
  double rmse_median_m = 0.0, rmse_max_m = 0.0;
  // With an event (kidnap or wrong start): runs in which the state said uncertain or lost within
  // evaluation.detection_deadline_s, and runs whose error was back under the threshold (to the
  // end) within evaluation.relocalization_deadline_s; the delays' median and maximum over the
  // runs that did.
  bool with_event = false;
  size_t detected = 0, relocalized = 0;
  std::optional<double> detection_delay_median_s, detection_delay_max_s;
  std::optional<double> relocalization_delay_median_s, relocalization_delay_max_s;
};

// Pools finished runs (their estimates carry NEES and states). Exposed for tests.
MonteCarloSummary pool_runs(const std::string& scenario, const std::string& plugin, uint64_t first_seed,
                            const EvaluationSpec& evaluation, const std::vector<RunResult>& runs);

// Runs `runs` seeds from first_seed. progress (may be null) gets one line per run.
MonteCarloSummary run_seeds(const Scenario& scenario, const OfflineRunOptions& options, int runs, uint64_t first_seed,
                            std::ostream* progress);

void write_montecarlo_json(std::ostream& out, const MonteCarloSummary& summary);
void write_montecarlo_summary(std::ostream& out, const MonteCarloSummary& summary);

}  // namespace locd::sim
