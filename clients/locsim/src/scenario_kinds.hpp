// The scenario kinds locsim runs. Each kind says which scenario files are its own and offers
// the commands it supports (run: offline straight through the plugin; live: against a running
// locd over DDS; montecarlo: many seeded runs); main() parses the command line into a Command,
// picks the kind of the scenario file and calls its entry point. A new kind (or a new command
// such as a replay) is one more entry in scenario_kinds().
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "live.hpp"

namespace locd::sim {

// Wrong usage: locsim prints the message and the usage, and exits with status 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// What the command line asked for.
struct Command {
  std::string mode;                                   // run, live, montecarlo
  std::filesystem::path scenario_file;
  bool json = false;                                  // one JSON object on stdout
  std::string plot_file;                              // PNG, empty = none
  std::string mcap_file;                              // run: record the run into MCAP, empty = none
  std::string trace_file;                             // run, live: every estimate as CSV, empty = none
  std::string rawlog_file;                            // run: also export as an MRPT rawlog
  std::optional<uint64_t> seed;                       // overrides the scenario's
  std::optional<double> duration_s;                   // overrides the scenario's
  std::vector<std::filesystem::path> plugin_directories;  // run, montecarlo
  LiveOptions live;                                   // live: domain, rate, server timeout
  int runs = 100;                                     // montecarlo
  // Segment worlds: a kidnap at kidnap_at_s to a route pose at least kidnap_distance_m away, or a
  // wrong start at least wrong_start_m off; either replaces the scenario's own kidnap / start.
  std::optional<double> kidnap_at_s, kidnap_distance_m, wrong_start_m;
  std::vector<std::string> strategies = {"known_id", "nearest_neighbor", "jcbb", "pda"};  // montecarlo
};

// An entry point returns the process exit code (0 ok, 1 failure, 2 no server / refused).
using Runner = std::function<int(const Command&)>;

struct ScenarioKind {
  std::string name;
  std::function<bool(const std::filesystem::path&)> matches;
  Runner run, live, montecarlo;  // empty: not offered for this kind
  std::string not_offered;       // why, when a command is not offered
};

// Every kind, most specific first; the last (segment-world scenarios) matches every file.
const std::vector<ScenarioKind>& scenario_kinds();
const ScenarioKind& kind_of(const std::filesystem::path& scenario_file);
// The kind's entry point for command.mode; UsageError when the kind does not offer it.
int run_command(const Command& command);

}  // namespace locd::sim
