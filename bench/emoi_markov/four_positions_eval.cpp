// emoi_four_positions_eval [SCENARIO.yaml] [--runs N] [--first-seed S] [--verbose]: the four-position
// experiment in-process (no DDS) over N seeds; prints each update's error and localization state,
// the success rate (belief maximum within success_radius_m of the truth after the last update),
// how often the state flagged a wrong maximum and how often it flagged a right one, and the
// consistency of the reported covariance (NEES, share outside the 99 % ellipse).
#include <cstring>
#include <iomanip>
#include <iostream>

#include "locd/sim_emoi_markov/four_positions.hpp"

namespace {

char state_letter(locd::LocalizationState state) {
  switch (state) {
    case locd::LocalizationState::kTracking: return 'T';
    case locd::LocalizationState::kUncertain: return 'U';
    case locd::LocalizationState::kLost: return 'L';
    default: return '?';
  }
}

bool flagged(locd::LocalizationState state) {
  return state == locd::LocalizationState::kUncertain || state == locd::LocalizationState::kLost;
}

// Counts of (right or wrong maximum) x (flagged or not).
struct Confusion {
  int wrong = 0, wrong_flagged = 0, wrong_lost = 0, right = 0, right_flagged = 0;
  void add(bool is_wrong, locd::LocalizationState state) {
    if (is_wrong) {
      ++wrong;
      wrong_flagged += flagged(state) ? 1 : 0;
      wrong_lost += state == locd::LocalizationState::kLost ? 1 : 0;
    } else {
      ++right;
      right_flagged += flagged(state) ? 1 : 0;
    }
  }
  void print(const char* what) const {
    std::cout << what << ": maximum wrong in " << wrong << ", flagged uncertain/lost in " << wrong_flagged << " ("
              << (wrong ? 100.0 * wrong_flagged / wrong : 0.0) << " %; lost " << wrong_lost << "); maximum right in "
              << right << ", flagged (false alarm) in " << right_flagged << " ("
              << (right ? 100.0 * right_flagged / right : 0.0) << " %)\n";
  }
};

}  // namespace

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
    Confusion final_state, every_update;
    locd::sim::emoi::PoseConsistency poses;
    double update_nees = 0.0, update_nees_heading = 0.0;
    int updates = 0, update_outside = 0, cell_successes = 0, mode_outside = 0, mode_updates = 0;
    double mode_nees = 0.0;
    std::cout << std::fixed << std::setprecision(2);
    for (int k = 0; k < runs; ++k) {
      const auto result = locd::sim::emoi::run_four_positions(scenario, seed0 + k);
      successes += result.success ? 1 : 0;
      update_ms += result.mean_update_ms;
      std::cout << "seed " << result.seed << (result.success ? "  ok  " : "  FAIL") << "  errors [m]:";
      for (const auto& u : result.updates) std::cout << " " << u.error_m;
      std::cout << "  states: ";
      for (const auto& u : result.updates) std::cout << state_letter(u.state);
      if (!result.updates.empty()) {
        const auto& last = result.updates.back();
        std::cout << "  last: peak mass " << last.peak_mass << ", truth mass " << last.truth_mass << ", modes "
                  << last.modes << ", area " << last.area_m2 << " m^2, NEES " << last.nees_position
                  << "; poses confidently wrong " << result.consistency.confidently_wrong;
      }
      std::cout << "\n" << std::flush;
      for (const auto& u : result.updates) {
        const bool wrong = u.error_m > scenario.success_radius_m;
        every_update.add(wrong, u.state);
        update_nees += u.nees_position;
        update_nees_heading += u.nees_heading;
        update_outside += u.nees_position > 9.2103 ? 1 : 0;
        if (u.nees_main_mode >= 0.0) {
          ++mode_updates;
          mode_nees += u.nees_main_mode;
          mode_outside += u.nees_main_mode > 9.2103 ? 1 : 0;
        }
        ++updates;
      }
      if (static_cast<int>(result.updates.size()) >= scenario.updates) {
        final_state.add(!result.success, result.updates.back().state);
        const double cell_error = result.updates.back().cell_maximum_error_m;
        cell_successes += cell_error >= 0.0 && cell_error <= scenario.success_radius_m ? 1 : 0;
      } else {
        final_state.add(true, locd::LocalizationState::kUnknown);
      }
      poses.poses += result.consistency.poses;
      poses.nees_position_sum += result.consistency.nees_position_sum;
      poses.nees_heading_sum += result.consistency.nees_heading_sum;
      poses.outside_99_position += result.consistency.outside_99_position;
      poses.outside_99_heading += result.consistency.outside_99_heading;
      poses.confidently_wrong += result.consistency.confidently_wrong;
      poses.tracking += result.consistency.tracking;
      poses.nees_position_tracking_sum += result.consistency.nees_position_tracking_sum;
      if (verbose) {
        for (const auto& u : result.updates) {
          std::cout << std::setprecision(4) << "    update " << u.update << " error " << u.error_m << " m; EMOI robot/DSM:";
          for (size_t i = 0; i < u.robot_emoi.size() && i < u.dsm_emoi.size(); ++i) {
            std::cout << " " << u.robot_emoi[i] << "/" << u.dsm_emoi[i] << " (cov " << u.coverage[i] << ")";
          }
          std::cout << std::setprecision(2) << "\n      " << state_letter(u.state) << " " << u.reason
                    << "; NEES " << u.nees_position << "; fit " << u.fit_rms_m << " m; peak mass " << u.peak_mass
                    << "\n";
        }
      }
    }
    std::cout << "success: " << successes << " / " << runs << " = " << (100.0 * successes / runs)
              << " % (maximum within " << scenario.success_radius_m << " m after update " << scenario.updates
              << "); mean sensor update " << update_ms / runs << " ms\n";
    std::cout << "the belief grid's most probable cell within " << scenario.success_radius_m << " m after update "
              << scenario.updates << ": " << cell_successes << " / " << runs << "\n";
    final_state.print("after the last update");
    every_update.print("after every update");
    std::cout << "sensor updates: " << updates << ", mean NEES position " << (updates ? update_nees / updates : 0.0)
              << " (2 dof), heading " << (updates ? update_nees_heading / updates : 0.0) << " (1 dof), outside the 99 % ellipse "
              << update_outside << " (" << (updates ? 100.0 * update_outside / updates : 0.0) << " %)\n";
    std::cout << "against the heaviest mode's covariance: mean NEES " << (mode_updates ? mode_nees / mode_updates : 0.0)
              << ", outside the 99 % ellipse " << mode_outside << " of " << mode_updates << "\n";
    const double n = static_cast<double>(std::max<size_t>(poses.poses, 1));
    std::cout << "every pose after the first update: " << poses.poses << ", mean NEES position "
              << poses.nees_position_sum / n << ", heading " << poses.nees_heading_sum / n
              << "; outside the 99 % ellipse: position " << poses.outside_99_position << " ("
              << 100.0 * poses.outside_99_position / n << " %), heading " << poses.outside_99_heading << " ("
              << 100.0 * poses.outside_99_heading / n << " %); tracking " << poses.tracking << " ("
              << 100.0 * poses.tracking / n << " %, mean NEES position while tracking "
              << (poses.tracking ? poses.nees_position_tracking_sum / static_cast<double>(poses.tracking) : 0.0)
              << "), confidently wrong (outside the 99 % ellipse while tracking) "
              << poses.confidently_wrong << " (" << 100.0 * poses.confidently_wrong / n << " %)\n";
  } catch (const std::exception& e) {
    std::cerr << "emoi_four_positions_eval: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
