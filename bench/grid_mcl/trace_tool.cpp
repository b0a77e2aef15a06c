// Prints one run's error and localization state over time (a debugging aid for the benchmarks):
//   grid_mcl_trace SCENARIO.yaml SEED DURATION [global|kidnap:T] [key=value ...]
#include <cstdio>
#include <string>

#include "locd/sim_grid_mcl/scenario_runs.hpp"

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: grid_mcl_trace SCENARIO.yaml SEED DURATION [global|kidnap:T] [key=value ...]\n");
    return 2;
  }
  locd::sim::grid::RunSpec spec;
  spec.scenario_file = argv[1];
  spec.seed = std::stoull(argv[2]);
  spec.duration_s = std::stod(argv[3]);
  for (int i = 4; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "global") {
      spec.global = true;
    } else if (a.rfind("kidnap:", 0) == 0) {
      spec.kidnap_at = std::stod(a.substr(7));
    } else if (const auto eq = a.find('='); eq != std::string::npos) {
      spec.params[a.substr(0, eq)] = a.substr(eq + 1);
    }
  }
  const locd::sim::grid::RunTrace trace = locd::sim::grid::run_scenario(spec);
  double next = 0.0;
  for (const auto& s : trace.samples) {
    if (s.t + 1e-9 < next) continue;
    std::printf("t %6.2f error %.3f heading %.3f state %s particles %zu (%s)\n", s.t, s.error, s.heading_error,
                locd::localization_state_name(s.state), s.particles, s.reason.c_str());
    next = s.t + 1.0;
  }
  std::printf("settled %.2f ", locd::sim::grid::settled_time(trace, 0.2, 0.0, spec.duration_s));
  std::printf("rmse after 10 s %.4f, ", locd::sim::grid::rmse(trace, 10.0));
  std::printf("rmse %.4f scans %zu update_ms %.3f max_particles %zu\n", locd::sim::grid::rmse(trace, 0.0), trace.scans,
              trace.update_ms_sum / std::max<size_t>(trace.scans, 1), trace.max_particles);
  return 0;
}
