// `locsim live` for icp_explorer's exploration mission (kind: icp_explorer_exploration): the
// offline mission (run_exploration_mission) drives a running locd through RemoteLocalizer, so
// the stop-scan-drive loop, the coverage and the registration error are measured exactly as in
// `locsim run`, only the localizer answers over DDS.
#pragma once

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>

#include "live.hpp"
#include "locd/client/client.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::sim {

// A Localizer whose work is done by a running locd: set_pose publishes the initial pose (and waits
// until the server acknowledged it), update publishes the measurement; for a cloud it waits for
// the pose and the exploration goal stamped like the cloud and returns them. Odometry returns at
// once (the server orders it before the cloud by stamp). Throws std::runtime_error on timeout.
class RemoteLocalizer : public Localizer {
 public:
  RemoteLocalizer(Client& client, std::chrono::milliseconds timeout);
  void configure(const PluginContext&, const Params&) override {}  // the session request configures
  void set_pose(const PoseEstimate& pose) override;
  UpdateResult update(const Measurement& measurement) override;

 private:
  Client& client_;
  const std::chrono::milliseconds timeout_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::map<int64_t, PoseEstimate> poses_;            // by stamp
  std::map<int64_t, ExplorationGoal> goals_;         // by stamp
};

int run_exploration_live(const std::filesystem::path& scenario_file, const LiveOptions& options,
                         std::optional<uint64_t> seed, bool json);

}  // namespace locd::sim
