// `locsim run`: a scenario straight through a plugin, no DDS. The plugin is loaded from a
// plugin directory exactly as the server loads it, given the start pose plus the configured
// offset, fed every measurement in stamp order; each estimate is scored against the truth at its
// stamp and each update timed.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/types.hpp"
#include "locd/sim/evaluator.hpp"
#include "locd/sim/scenario.hpp"
#include "locd/sim/simulation.hpp"

namespace locd::sim {

// Sees a run as it happens (locsim run --mcap records it). Calls come in run order.
class RunObserver {
 public:
  virtual ~RunObserver() = default;
  virtual void started(const PoseEstimate& initial_pose) {}
  // Every measurement handed to the plugin, with the truth at its time.
  virtual void measurement(const Measurement& m, const Pose2& truth) {}
  virtual void updated(const UpdateResult& update, double update_ms) {}
};

struct OfflineRunOptions {
  std::vector<std::filesystem::path> plugin_directories;
  std::optional<uint64_t> seed;        // overrides the scenario's
  std::optional<double> duration_s;    // overrides the scenario's
  RunObserver* observer = nullptr;     // optional
};

struct RunResult {
  std::string plugin;
  std::string scenario;
  std::string robot_id;
  uint64_t seed = 0;
  double duration_s = 0;
  size_t measurements = 0;  // fed to the plugin
  size_t rejected = 0;      // refused by the plugin (InputError)
  std::string last_rejection;
  std::optional<SimulatedEvent> event;  // a kidnap or wrong start, when the scenario has one
  EvaluationSummary summary;
  std::vector<ScoredEstimate> estimates;
  std::vector<Pose2> truth_path;  // at the truth sample rate
};

RunResult run_offline(const Scenario& scenario, const OfflineRunOptions& options);

}  // namespace locd::sim
