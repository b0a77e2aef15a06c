// `locsim live`: the scenario in real time against a running locd over DDS.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "locd/client/client.hpp"
#include "locd/sim/scenario.hpp"

namespace locd::sim {

struct LiveOptions {
  uint32_t domain_id = 0;
  double rate = 1.0;  // sim seconds per wall second
  std::optional<uint64_t> seed;
  std::optional<double> duration_s;
  bool json = false;
  std::string plot_file;
  double server_timeout_s = 10.0;
  // Non-empty: the robot speaks ROS 2 in this namespace (scans and odometry out, the pose in as
  // PoseWithCovarianceStamped); the session config gets the matching `ros2:` section.
  std::string ros2_namespace;
};

// Returns the process exit code; prints progress to stderr (json) or stdout.
int run_live(const Scenario& scenario, const LiveOptions& options);

// options.server_timeout_s as a duration.
std::chrono::milliseconds server_timeout(const LiveOptions& options);
// Waits for a locd server on the client's domain; false (after saying so on stderr, naming the
// domain) when none answers within the server timeout.
bool wait_for_server(Client& client, const LiveOptions& options);

}  // namespace locd::sim
