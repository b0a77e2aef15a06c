// grid_mcl's accuracy on both grid scenarios (config/scenarios/corridor_grid.yaml and
// warehouse.yaml, each with its shipped plugin config), through the plugin's Localizer in-process
// (scenario_runs.hpp). Each benchmark runs once and reports counters.
//   BM_Tracking/scenario        10 seeds from the scenario's initial pose (truth + 0.36 m, 3 deg):
//                               RMSE over every estimate after the first 10 s, pooled, the worst
//                               seed's, and the RMSE over the whole run (the start included)
//   BM_GlobalLocalization/scenario  20 seeds from a uniform start: share of runs whose error is
//                               below 0.2 m within 30 s of driving and stays so to 60 s
//   BM_Kidnapping/scenario      10 seeds: at 40 s the robot is carried 20 s further along its route
//                               unseen by odometry; share recovered (error below 0.2 m, staying)
//                               within 30 s, and the mean time
// scenario 0: corridor_grid, 1: warehouse.
// Run: build/bin/grid_mcl_accuracy_bench   (several minutes on one core)
#include <benchmark/benchmark.h>

#include "locd/sim_grid_mcl/scenario_runs.hpp"

namespace {

using namespace locd;
using namespace locd::sim::grid;

std::string scenario_file(int64_t which) { return std::string(LOCD_SOURCE_DIR) + "/config/scenarios/" + (which == 0 ? "corridor_grid.yaml" : "warehouse.yaml"); }

void BM_Tracking(benchmark::State& state) {
  const double duration = state.range(0) == 0 ? 120.0 : 180.0;
  double sum = 0.0, whole_sum = 0.0, worst = 0.0;
  size_t n = 0, whole_n = 0;
  for (auto _ : state) {
    for (uint64_t seed = 1; seed <= 10; ++seed) {
      RunSpec spec;
      spec.scenario_file = scenario_file(state.range(0));
      spec.seed = seed;
      spec.duration_s = duration;
      const RunTrace t = run_scenario(spec);
      worst = std::max(worst, rmse(t, 10.0));
      for (const TraceSample& s : t.samples) {
        whole_sum += s.error * s.error;
        ++whole_n;
        if (s.t < 10.0) continue;
        sum += s.error * s.error;
        ++n;
      }
    }
  }
  state.counters["runs"] = 10;
  state.counters["rmse_after_10s_m"] = std::sqrt(sum / static_cast<double>(n));
  state.counters["worst_seed_rmse_after_10s_m"] = worst;
  state.counters["rmse_whole_run_m"] = std::sqrt(whole_sum / static_cast<double>(whole_n));
}
BENCHMARK(BM_Tracking)->ArgName("scenario")->Arg(0)->Arg(1)->Iterations(1)->Unit(benchmark::kSecond);

void BM_GlobalLocalization(benchmark::State& state) {
  int converged = 0, runs = 0;
  std::vector<double> times;
  for (auto _ : state) {
    for (uint64_t seed = 1; seed <= 20; ++seed) {
      RunSpec spec;
      spec.scenario_file = scenario_file(state.range(0));
      spec.seed = seed;
      spec.duration_s = 60.0;
      spec.global = true;
      const double settled = settled_time(run_scenario(spec), 0.2, 0.0, 60.0);
      ++runs;
      if (settled >= 0.0 && settled <= 30.0) {
        ++converged;
        times.push_back(settled);
      }
    }
  }
  state.counters["runs"] = runs;
  state.counters["converged_within_30s"] = converged;
  state.counters["mean_time_to_converge_s"] = mean(times);
  state.counters["max_time_to_converge_s"] = times.empty() ? NAN : *std::max_element(times.begin(), times.end());
}
BENCHMARK(BM_GlobalLocalization)->ArgName("scenario")->Arg(0)->Arg(1)->Iterations(1)->Unit(benchmark::kSecond);

void BM_Kidnapping(benchmark::State& state) {
  int recovered = 0, runs = 0;
  std::vector<double> times;
  for (auto _ : state) {
    for (uint64_t seed = 1; seed <= 10; ++seed) {
      RunSpec spec;
      spec.scenario_file = scenario_file(state.range(0));
      spec.seed = seed;
      spec.kidnap_at = 40.0;
      spec.kidnap_ahead_s = 20.0;
      spec.duration_s = 100.0;
      const double settled = settled_time(run_scenario(spec), 0.2, spec.kidnap_at, spec.duration_s);
      ++runs;
      if (settled >= 0.0 && settled - spec.kidnap_at <= 30.0) {
        ++recovered;
        times.push_back(settled - spec.kidnap_at);
      }
    }
  }
  state.counters["runs"] = runs;
  state.counters["recovered_within_30s"] = recovered;
  state.counters["mean_time_to_recover_s"] = mean(times);
  state.counters["max_time_to_recover_s"] = times.empty() ? NAN : *std::max_element(times.begin(), times.end());
}
BENCHMARK(BM_Kidnapping)->ArgName("scenario")->Arg(0)->Arg(1)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
