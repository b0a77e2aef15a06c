// One offline locsim run of a shipped scenario (config/scenarios/NAME.yaml) through the built
// plugins, with an optional kidnap at `kidnap_at` s (at least 10 m) or a wrong start at least
// `wrong_start` m off (instead of the scenario's initial offset).
#pragma once

#include <optional>
#include <string>

#include "locd/sim/offline_runner.hpp"
#include "test_env.hpp"

namespace locd::test {

inline sim::RunResult offline_run(const std::string& scenario_name, uint64_t seed, double duration_s,
                                  std::optional<double> kidnap_at, std::optional<double> wrong_start = std::nullopt) {
  sim::Scenario scenario = sim::load_scenario(source_dir() + "/config/scenarios/" + scenario_name + ".yaml");
  if (kidnap_at) scenario.kidnap = sim::KidnapSpec{*kidnap_at, std::nullopt, 10.0};
  if (wrong_start) {
    scenario.localizer.wrong_start_min_distance_m = *wrong_start;
    scenario.localizer.initial_pose_offset = {};
  }
  sim::OfflineRunOptions options;
  options.plugin_directories = {plugin_dir()};
  options.seed = seed;
  options.duration_s = duration_s;
  return sim::run_offline(scenario, options);
}

}  // namespace locd::test
