#include "locd/sim/offline_runner.hpp"

#include <chrono>

#include "locd/sdk/plugin_loader.hpp"
#include "locd/sdk/validate.hpp"
#include "locd/sim/simulation.hpp"

namespace locd::sim {

RunResult run_offline(const Scenario& scenario, const OfflineRunOptions& options) {
  RunResult result;
  result.plugin = scenario.localizer.plugin;
  result.scenario = scenario.name;
  result.robot_id = scenario.robot.id;
  result.seed = options.seed.value_or(scenario.seed);
  result.duration_s = options.duration_s.value_or(scenario.duration_s);

  const PluginCatalog catalog(options.plugin_directories);
  PluginContext context;
  context.robot_id = scenario.robot.id;
  context.maps = MapResolver(scenario.map_directories);
  LocalizerPtr localizer = create_configured(catalog, scenario.localizer.plugin, context, scenario.localizer.params);

  Simulation simulation(scenario, result.seed, result.duration_s);
  localizer->set_pose(simulation.initial_pose());
  if (options.observer) options.observer->started(simulation.initial_pose());
  TrajectoryEvaluator evaluator(scenario.convergence_threshold_m, simulation.event() ? std::optional<double>(simulation.event()->t) : std::nullopt);
  result.event = simulation.event();
  LocalizationState state = LocalizationState::kUnknown;  // the plugin's last judgement
  while (auto m = simulation.next()) {
    ++result.measurements;
    if (options.observer) options.observer->measurement(m->measurement, simulation.truth().at(m->t).pose);
    UpdateResult update;
    const auto begin = std::chrono::steady_clock::now();
    try {
      validate(m->measurement);  // as the server's bridge does: the plugin trusts what it is given
      update = localizer->update(m->measurement);
    } catch (const InputError& e) {
      ++result.rejected;
      result.last_rejection = m->sensor + ": " + e.what();
      continue;
    }
    const double update_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
    if (options.observer) options.observer->updated(update, update_ms);
    if (update.localization) state = update.localization->state;
    if (!update.estimate) continue;
    const double t = simulation.time_of(update.estimate->header.stamp_ns);
    evaluator.add(t, *update.estimate, simulation.truth().at(t).pose, state, update_ms);
  }
  result.summary = evaluator.summary();
  result.estimates = evaluator.estimates();
  for (const auto& s : simulation.truth().samples()) result.truth_path.push_back(s.pose);
  return result;
}

}  // namespace locd::sim
