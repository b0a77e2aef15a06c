#include "scenario_kinds.hpp"

#include <iostream>

#include "live_emoi_markov.hpp"
#include "live_exploration.hpp"
#include "run_recording.hpp"
#include "locd/sim/montecarlo.hpp"
#include "locd/sim/offline_runner.hpp"
#include "locd/sim/report.hpp"
#include "locd/sim/scenario.hpp"
#include "locd/sim_emoi_markov/four_positions.hpp"
#include "locd/sim_feature_ekf/montecarlo.hpp"
#include "locd/sim_grid_mcl/rawlog_export.hpp"
#include "locd/sim_icp_explorer/exploration_mission.hpp"

namespace locd::sim {
namespace {

namespace rs = road_signs;

// Where the progress and plot lines go: stderr when stdout carries the JSON.
std::ostream& log_stream(const Command& c) { return c.json ? std::cerr : std::cout; }

int road_signs_montecarlo(const Command& c, int runs) {
  rs::MonteCarloOptions options;
  options.scenario_file = c.scenario_file;
  options.plugin_directories = c.plugin_directories;
  options.seed = c.seed;
  options.duration_s = c.duration_s;
  options.runs = runs;
  options.strategies = c.strategies;
  const rs::MonteCarloResult result = rs::run_montecarlo(options);
  if (c.json) {
    rs::write_montecarlo_json(std::cout, result);
  } else {
    rs::write_montecarlo_summary(std::cout, result);
  }
  if (!c.plot_file.empty()) {
    rs::plot_montecarlo(c.plot_file, result);
    log_stream(c) << "plot: " << c.plot_file << "\n";
  }
  return 0;
}

// The scenario with the command line's kidnap or wrong start in place of its own.
Scenario segment_scenario(const Command& c) {
  Scenario scenario = load_scenario(c.scenario_file);
  const double duration = c.duration_s.value_or(scenario.duration_s);
  if (c.kidnap_distance_m && !c.kidnap_at_s) throw UsageError("--kidnap-distance needs --kidnap-at");
  if (c.kidnap_at_s && c.wrong_start_m) throw UsageError("--kidnap-at and --wrong-start exclude each other");
  if (c.kidnap_at_s) {
    if (*c.kidnap_at_s >= duration) {
      throw UsageError("--kidnap-at " + std::to_string(*c.kidnap_at_s) + ": must be before the end of the run (" +
                       std::to_string(duration) + " s)");
    }
    scenario.kidnap = KidnapSpec{*c.kidnap_at_s, std::nullopt, c.kidnap_distance_m.value_or(KidnapSpec{}.min_distance_m)};
    scenario.localizer.wrong_start_min_distance_m.reset();
  }
  if (c.wrong_start_m) {
    scenario.localizer.wrong_start_min_distance_m = *c.wrong_start_m;
    scenario.kidnap.reset();
  }
  return scenario;
}

int segment_world_montecarlo(const Command& c) {
  const Scenario scenario = segment_scenario(c);
  const OfflineRunOptions options{c.plugin_directories, std::nullopt, c.duration_s, nullptr};
  const MonteCarloSummary summary = run_seeds(scenario, options, c.runs, c.seed.value_or(1), &log_stream(c));
  if (c.json) {
    write_montecarlo_json(std::cout, summary);
  } else {
    write_montecarlo_summary(std::cout, summary);
  }
  return summary.runs.empty() ? 1 : 0;
}

int segment_world_run(const Command& c) {
  const Scenario scenario = segment_scenario(c);
  std::unique_ptr<McapRunRecording> recording;
  if (!c.mcap_file.empty()) recording = std::make_unique<McapRunRecording>(c.mcap_file, scenario);
  const RunResult result =
      run_offline(scenario, OfflineRunOptions{c.plugin_directories, c.seed, c.duration_s, recording.get()});
  if (recording) {
    recording->close();
    log_stream(c) << "recording: " << c.mcap_file << "\n";
  }
  report_run(result, scenario.map, c.json, c.plot_file);
  if (!c.trace_file.empty()) {
    write_trace(c.trace_file, result);
    log_stream(c) << "trace: " << c.trace_file << "\n";
  }
  if (!c.rawlog_file.empty()) {
    const grid::RawlogExport e = grid::export_rawlog(scenario, result.seed, result.duration_s, c.rawlog_file);
    log_stream(c) << "rawlog: " << e.rawlog.string() << " (" << e.scans << " scans; truth " << e.truth.string() << ")\n";
  }
  return result.summary.updates > 0 ? 0 : 1;
}

int segment_world_live(const Command& c) {
  LiveOptions live = c.live;
  live.seed = c.seed;
  live.duration_s = c.duration_s;
  live.json = c.json;
  live.plot_file = c.plot_file;
  return run_live(segment_scenario(c), live);
}

}  // namespace

const std::vector<ScenarioKind>& scenario_kinds() {
  static const std::vector<ScenarioKind> kinds = {
      {"road_signs (feature_ekf landmarks: sensors.sign_detector)", rs::is_road_signs_scenario,
       [](const Command& c) { return road_signs_montecarlo(c, 1); },  // one drive per strategy
       {},
       [](const Command& c) { return road_signs_montecarlo(c, c.runs); },
       "the road-sign scenario runs offline only: locsim run or locsim montecarlo"},
      {"emoi_four_positions (emoi_markov)", emoi::is_four_positions_scenario,
       [](const Command& c) {
         return emoi::locsim_run_four_positions(c.scenario_file, c.plugin_directories, c.seed, c.json, std::cout);
       },
       [](const Command& c) { return run_four_positions_live(c.scenario_file, c.live, c.seed, c.json); },
       {},
       "locsim montecarlo needs a road-sign scenario (sensors.sign_detector), e.g. config/scenarios/road_signs.yaml"},
      {"icp_explorer_exploration (icp_explorer)", is_exploration_scenario,
       [](const Command& c) {
         return locsim_run_exploration(c.scenario_file, c.plugin_directories, c.seed, c.json, std::cout);
       },
       [](const Command& c) { return run_exploration_live(c.scenario_file, c.live, c.seed, c.json); },
       {},
       "locsim montecarlo needs a road-sign scenario (sensors.sign_detector), e.g. config/scenarios/road_signs.yaml"},
      {"segment world (laser, odometry, ceiling camera)", [](const std::filesystem::path&) { return true; },
       segment_world_run, segment_world_live, segment_world_montecarlo, ""},
  };
  return kinds;
}

const ScenarioKind& kind_of(const std::filesystem::path& scenario_file) {
  for (const ScenarioKind& kind : scenario_kinds()) {
    if (kind.matches(scenario_file)) return kind;
  }
  return scenario_kinds().back();
}

int run_command(const Command& command) {
  const ScenarioKind& kind = kind_of(command.scenario_file);
  if (!command.trace_file.empty() && &kind != &scenario_kinds().back()) {
    throw UsageError("--trace writes segment-world runs (corridor, ceiling hall, grid worlds); not offered for " + kind.name);
  }
  if (!command.mcap_file.empty() && &kind != &scenario_kinds().back()) {
    throw UsageError("--mcap records segment-world runs (corridor, ceiling hall); not offered for " + kind.name);
  }
  if ((command.kidnap_at_s || command.kidnap_distance_m || command.wrong_start_m) && &kind != &scenario_kinds().back()) {
    throw UsageError("--kidnap-at, --kidnap-distance and --wrong-start apply to segment-world scenarios (corridor, "
                     "ceiling hall, grid worlds), not to a " + kind.name + " scenario");
  }
  const Runner& runner = command.mode == "run" ? kind.run : command.mode == "live" ? kind.live : kind.montecarlo;
  if (!runner) throw UsageError(kind.not_offered);
  if (!command.live.ros2_namespace.empty() && &kind != &scenario_kinds().back()) {
    throw UsageError("--ros2 plays a laser-and-odometry robot of a segment-world scenario (e.g. "
                     "config/scenarios/corridor.yaml), not a " + kind.name + " scenario");
  }
  return runner(command);
}

}  // namespace locd::sim
