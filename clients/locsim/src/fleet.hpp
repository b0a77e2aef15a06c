// `locsim fleet`: N simulated robots in one process against running locd servers over DDS, the
// tool to size servers with. Every robot drives a scenario (K distinct simulated runs, robot i
// replays run i mod K under its own id and clock, its messages offset so the fleet's load is
// spread evenly over time), asks for its own session, and numbers its sensor streams. Reported:
// poses per second, latency (publish -> pose) p50 / p99 / max, messages the servers counted as
// lost in transit, dropped or rejected, the generator's own lag, and (with --server-pid, for a
// server on this machine) the server's CPU and memory with its plugin workers; as JSON or a
// summary, and a plot of poses per second and latency over the run; on request, how each robot
// came back after its longest wait for a pose (a server restarted, or taken over).
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "locd/sim/scenario.hpp"

namespace locd::sim {

struct FleetOptions {
  uint32_t domain_id = 0;
  size_t robots = 10;
  double rate = 1.0;                 // sim seconds per wall second (all sensor rates scale with it)
  std::optional<uint64_t> seed;      // of the first distinct run; run k uses seed + k
  std::optional<double> duration_s;  // default: the scenario's
  size_t distinct_runs = 8;          // K: simulated runs the robots share
  std::vector<pid_t> server_pids;    // servers to measure (their plugin workers included)
  bool json = false;
  std::string plot_file;
  double server_timeout_s = 60.0;    // for every session to start and take its initial pose
  std::string robot_prefix = "fleet_";
  // Per robot: when its longest wait between two poses ended (wall clock), and the position error
  // of the pose that ended it and of the poses 1 s and 5 s (robot time) later: how a fleet comes
  // back after its server was down (bench/server/site_restart.sh).
  bool outage_report = false;
};

// Returns the process exit code.
int run_fleet(const Scenario& scenario, const FleetOptions& options);

}  // namespace locd::sim
