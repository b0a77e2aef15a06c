// locsim: simulated robots for locd. `run` drives a scenario offline straight through a plugin;
// `live` publishes it in real time to a running locd over DDS. Both score the estimates.
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "live.hpp"
#include "live_emoi_markov.hpp"
#include "live_exploration.hpp"
#include "locd/sim/offline_runner.hpp"
#include "locd/sim/report.hpp"
#include "locd/sim/scenario.hpp"
#include "locd/sim_feature_ekf/montecarlo.hpp"
#include "locd/sim_emoi_markov/four_positions.hpp"
#include "locd/sim_icp_explorer/exploration_mission.hpp"

namespace fs = std::filesystem;

namespace {

const char* kUsage =
    "usage:\n"
    "  locsim run SCENARIO.yaml [--json] [--plot FILE.png] [--plugin-dir DIR] [--seed N] [--duration S]\n"
    "      offline: the scenario straight through the plugin, no DDS\n"
    "  locsim live SCENARIO.yaml [--domain N] [--rate X] [--duration S] [--seed N] [--json] [--plot FILE.png]\n"
    "              [--server-timeout S]\n"
    "      real time against a running locd (DDS through CYCLONEDDS_URI); --rate 2 runs twice as fast;\n"
    "      waits --server-timeout seconds (default 10) for the server and each answer\n"
    "  locsim montecarlo SCENARIO.yaml [--runs N] [--strategies a,b,...] [--json] [--plot FILE.png]\n"
    "                   [--plugin-dir DIR] [--seed N] [--duration S]\n"
    "      a road-sign scenario (feature_ekf landmarks), N seeded drives per association strategy\n"
    "      (default: known_id, nearest_neighbor, jcbb, pda) side by side: CEP50/CEP95, wrong associations\n"
    "  locsim --help\n"
    "Plugin directory for run: --plugin-dir, else $LOCD_PLUGIN_DIR, else <locsim's dir>/../plugins.\n";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

double parse_number(const std::string& option, const std::string& text, double min, double max) {
  try {
    size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size() && v >= min && v <= max) return v;
  } catch (const std::exception&) {
  }
  throw UsageError(option + " " + text + ": expected a number in [" + std::to_string(min) + ", " +
                   std::to_string(max) + "]");
}

uint64_t parse_unsigned(const std::string& option, const std::string& text, uint64_t max) {
  try {
    size_t used = 0;
    const unsigned long long v = std::stoull(text, &used);
    if (used == text.size() && text[0] != '-' && v <= max) return v;
  } catch (const std::exception&) {
  }
  throw UsageError(option + " " + text + ": expected an integer in [0, " + std::to_string(max) + "]");
}

fs::path default_plugin_directory() {
  if (const char* env = std::getenv("LOCD_PLUGIN_DIR"); env && *env) return env;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return "plugins";
  return self.parent_path() / ".." / "plugins";
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h") {
    (args.empty() ? std::cerr : std::cout) << kUsage;
    return args.empty() ? 2 : 0;
  }
  try {
    const std::string mode = args[0];
    if (mode != "run" && mode != "live" && mode != "montecarlo") throw UsageError("unknown command '" + mode + "'; known: run, live, montecarlo");
    std::string scenario_file, plot_file;
    bool json = false;
    std::optional<uint64_t> seed;
    std::optional<double> duration;
    std::vector<fs::path> plugin_directories;
    locd::sim::LiveOptions live;
    locd::sim::road_signs::MonteCarloOptions road_signs;
    for (size_t i = 1; i < args.size(); ++i) {
      const std::string& a = args[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= args.size()) throw UsageError(a + " needs a value");
        return args[++i];
      };
      if (a == "--json") {
        json = true;
      } else if (a == "--plot") {
        plot_file = value();
      } else if (a == "--seed") {
        seed = parse_unsigned(a, value(), std::numeric_limits<long>::max());
      } else if (a == "--duration") {
        duration = parse_number(a, value(), 1e-3, 86400.0);
      } else if (a == "--runs" && mode == "montecarlo") {
        road_signs.runs = static_cast<int>(parse_unsigned(a, value(), 100000));
      } else if (a == "--strategies" && mode == "montecarlo") {
        road_signs.strategies.clear();
        std::stringstream list(value());
        for (std::string name; std::getline(list, name, ',');) road_signs.strategies.push_back(name);
      } else if (a == "--plugin-dir" && (mode == "run" || mode == "montecarlo")) {
        plugin_directories.push_back(value());
      } else if (a == "--domain" && mode == "live") {
        live.domain_id = static_cast<uint32_t>(parse_unsigned(a, value(), 232));
      } else if (a == "--server-timeout" && mode == "live") {
        live.server_timeout_s = parse_number(a, value(), 0.1, 3600.0);
      } else if (a == "--rate" && mode == "live") {
        live.rate = parse_number(a, value(), 0.01, 100.0);
      } else if (a == "--help" || a == "-h") {
        std::cout << kUsage;
        return 0;
      } else if (!a.empty() && a[0] != '-' && scenario_file.empty()) {
        scenario_file = a;
      } else {
        throw UsageError("unknown option '" + a + "' for locsim " + mode);
      }
    }
    if (scenario_file.empty()) throw UsageError("locsim " + mode + " needs a SCENARIO.yaml");
    // feature_ekf's road-sign scenarios: `run` is one drive per strategy, `montecarlo` N drives.
    if (mode == "live" && locd::sim::road_signs::is_road_signs_scenario(scenario_file)) {
      throw UsageError("the road-sign scenario runs offline only: locsim run or locsim montecarlo");
    }
    if (mode == "montecarlo" || (mode == "run" && locd::sim::road_signs::is_road_signs_scenario(scenario_file))) {
      if (!locd::sim::road_signs::is_road_signs_scenario(scenario_file)) {
        throw UsageError("locsim montecarlo needs a road-sign scenario (sensors.sign_detector), e.g. config/scenarios/road_signs.yaml");
      }
      if (plugin_directories.empty()) plugin_directories.push_back(default_plugin_directory());
      road_signs.scenario_file = scenario_file;
      road_signs.plugin_directories = plugin_directories;
      road_signs.seed = seed;
      road_signs.duration_s = duration;
      if (mode == "run") road_signs.runs = 1;
      const auto result = locd::sim::road_signs::run_montecarlo(road_signs);
      if (json) {
        locd::sim::road_signs::write_montecarlo_json(std::cout, result);
      } else {
        locd::sim::road_signs::write_montecarlo_summary(std::cout, result);
      }
      if (!plot_file.empty()) {
        locd::sim::road_signs::plot_montecarlo(plot_file, result);
        (json ? std::cerr : std::cout) << "plot: " << plot_file << "\n";
      }
      return 0;
    }
    if (locd::sim::emoi::is_four_positions_scenario(scenario_file)) {  // emoi_markov's experiment
      if (mode == "live") return locd::sim::run_four_positions_live(scenario_file, live, seed, json);
      if (plugin_directories.empty()) plugin_directories.push_back(default_plugin_directory());
      return locd::sim::emoi::locsim_run_four_positions(scenario_file, plugin_directories, seed, json, std::cout);
    }
    if (locd::sim::is_exploration_scenario(scenario_file)) {  // icp_explorer's exploration mission
      if (mode == "live") return locd::sim::run_exploration_live(scenario_file, live, seed, json);
      if (plugin_directories.empty()) plugin_directories.push_back(default_plugin_directory());
      return locd::sim::locsim_run_exploration(scenario_file, plugin_directories, seed, json, std::cout);
    }
    const locd::sim::Scenario scenario = locd::sim::load_scenario(scenario_file);

    if (mode == "live") {
      live.seed = seed;
      live.duration_s = duration;
      live.json = json;
      live.plot_file = plot_file;
      return locd::sim::run_live(scenario, live);
    }
    if (plugin_directories.empty()) plugin_directories.push_back(default_plugin_directory());
    locd::sim::OfflineRunOptions options{plugin_directories, seed, duration};
    const locd::sim::RunResult result = locd::sim::run_offline(scenario, options);
    if (json) {
      locd::sim::write_json(std::cout, result);
    } else {
      locd::sim::write_summary(std::cout, result);
    }
    if (!plot_file.empty()) {
      locd::sim::plot_run(plot_file, scenario.map, result);
      (json ? std::cerr : std::cout) << "plot: " << plot_file << "\n";
    }
    return result.summary.updates > 0 ? 0 : 1;
  } catch (const UsageError& e) {
    std::cerr << "locsim: " << e.what() << "\n" << kUsage;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "locsim: " << e.what() << "\n";
    return 1;
  }
}
