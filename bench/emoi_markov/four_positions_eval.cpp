// emoi_four_positions_eval [SCENARIO.yaml] [--runs N] [--first-seed S] [--verbose]: the four-position
// experiment in-process (no DDS) over N seeds; prints each update's error and the success rate
// (belief maximum within success_radius_m of the truth after the last update).
#include <cstring>
#include <iomanip>
#include <iostream>

#include "locd/sim_emoi_markov/four_positions.hpp"

int main(int argc, char** argv) {
  std::string file = "config/scenarios/emoi_four_positions.yaml";
  int runs = -1;
  long first_seed = -1;
  bool verbose = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) {
      runs = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--first-seed") && i + 1 < argc) {
      first_seed = std::atol(argv[++i]);
    } else if (!std::strcmp(argv[i], "--verbose")) {
      verbose = true;
    } else {
      file = argv[i];
    }
  }
  try {
    const auto scenario = locd::sim::emoi::load_four_positions(file);
    if (runs < 0) runs = scenario.runs;
    const uint64_t seed0 = first_seed >= 0 ? static_cast<uint64_t>(first_seed) : scenario.seed;
    int successes = 0;
    double update_ms = 0.0;
    std::cout << std::fixed << std::setprecision(2);
    for (int k = 0; k < runs; ++k) {
      const auto result = locd::sim::emoi::run_four_positions(scenario, seed0 + k);
      successes += result.success ? 1 : 0;
      update_ms += result.mean_update_ms;
      std::cout << "seed " << result.seed << (result.success ? "  ok  " : "  FAIL") << "  errors [m]:";
      for (const auto& u : result.updates) std::cout << " " << u.error_m;
      std::cout << "  coverage@last:";
      if (!result.updates.empty()) {
        for (double c : result.updates.back().coverage) std::cout << " " << c;
      }
      std::cout << "  layers " << result.layers_seconds << " s\n" << std::flush;
      if (verbose) {
        for (const auto& u : result.updates) {
          std::cout << std::setprecision(4) << "    update " << u.update << " error " << u.error_m << " m; EMOI robot/DSM:";
          for (size_t i = 0; i < u.robot_emoi.size() && i < u.dsm_emoi.size(); ++i) {
            std::cout << " " << u.robot_emoi[i] << "/" << u.dsm_emoi[i] << " (cov " << u.coverage[i] << ")";
          }
          std::cout << std::setprecision(2) << "\n";
        }
      }
    }
    std::cout << "success: " << successes << " / " << runs << " = " << (100.0 * successes / runs)
              << " % (maximum within " << scenario.success_radius_m << " m after update " << scenario.updates
              << "); mean sensor update " << update_ms / runs << " ms\n";
  } catch (const std::exception& e) {
    std::cerr << "emoi_four_positions_eval: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
