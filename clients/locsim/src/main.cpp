// locsim: simulated robots for locd. `run` drives a scenario offline straight through a plugin;
// `live` publishes it in real time to a running locd over DDS; `montecarlo` runs many seeded
// drives. The command line (CLI11) becomes a Command; the scenario's kind (scenario_kinds.hpp)
// runs it.
#include <CLI/CLI.hpp>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "scenario_kinds.hpp"

namespace fs = std::filesystem;
using locd::sim::Command;
using locd::sim::UsageError;

namespace {

const char* kUsage =
    "usage:\n"
    "  locsim run SCENARIO.yaml [--json] [--plot FILE.png] [--plugin-dir DIR] [--seed N] [--duration S]\n"
    "             [--rawlog FILE.rawlog]\n"
    "      offline: the scenario straight through the plugin, no DDS; --rawlog also writes the run\n"
    "      as an MRPT rawlog (laser scenarios; needs carmen2rawlog from mrpt-apps)\n"
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

// Numbers are read as text by CLI11 and converted here, so every message names the option, the
// value and the allowed range.
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

// The options as text, before conversion.
struct Text {
  std::string scenario, seed, duration, runs, strategies, domain, server_timeout, rate;
  std::vector<std::string> plugin_directories;
};

Command parse(const std::vector<std::string>& args) {
  const std::string mode = args[0];
  if (mode != "run" && mode != "live" && mode != "montecarlo") {
    throw UsageError("unknown command '" + mode + "'; known: run, live, montecarlo");
  }
  Command c;
  c.mode = mode;
  Text text;
  CLI::App app{"locsim", "locsim"};
  app.set_help_flag();
  app.add_option("scenario", text.scenario, "SCENARIO.yaml");
  app.add_flag("--json", c.json);
  app.add_option("--plot", c.plot_file);
  app.add_option("--seed", text.seed);
  app.add_option("--duration", text.duration);
  if (mode == "run" || mode == "montecarlo") {
    app.add_option("--plugin-dir", text.plugin_directories)->expected(1)->take_all();
  }
  if (mode == "run") app.add_option("--rawlog", c.rawlog_file);
  if (mode == "live") {
    app.add_option("--domain", text.domain);
    app.add_option("--server-timeout", text.server_timeout);
    app.add_option("--rate", text.rate);
  }
  if (mode == "montecarlo") {
    app.add_option("--runs", text.runs);
    app.add_option("--strategies", text.strategies);
  }
  std::vector<std::string> rest(args.rbegin(), args.rend() - 1);  // CLI11 takes them last first
  try {
    app.parse(rest);
  } catch (const CLI::ParseError& e) {
    throw UsageError(std::string(e.what()) + " (locsim " + mode + ")");
  }
  if (!text.seed.empty()) c.seed = parse_unsigned("--seed", text.seed, std::numeric_limits<long>::max());
  if (!text.duration.empty()) c.duration_s = parse_number("--duration", text.duration, 1e-3, 86400.0);
  if (!text.runs.empty()) c.runs = static_cast<int>(parse_unsigned("--runs", text.runs, 100000));
  if (!text.strategies.empty()) {
    c.strategies.clear();
    std::stringstream list(text.strategies);
    for (std::string name; std::getline(list, name, ',');) c.strategies.push_back(name);
  }
  if (!text.domain.empty()) c.live.domain_id = static_cast<uint32_t>(parse_unsigned("--domain", text.domain, 232));
  if (!text.server_timeout.empty()) {
    c.live.server_timeout_s = parse_number("--server-timeout", text.server_timeout, 0.1, 3600.0);
  }
  if (!text.rate.empty()) c.live.rate = parse_number("--rate", text.rate, 0.01, 100.0);
  for (const std::string& d : text.plugin_directories) c.plugin_directories.push_back(d);
  if (c.plugin_directories.empty()) c.plugin_directories.push_back(default_plugin_directory());
  if (text.scenario.empty()) throw UsageError("locsim " + mode + " needs a SCENARIO.yaml");
  c.scenario_file = text.scenario;
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) {
    std::cerr << kUsage;
    return 2;
  }
  for (const std::string& a : args) {
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    }
  }
  try {
    return locd::sim::run_command(parse(args));
  } catch (const UsageError& e) {
    std::cerr << "locsim: " << e.what() << "\n" << kUsage;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "locsim: " << e.what() << "\n";
    return 1;
  }
}
