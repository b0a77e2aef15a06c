// `locsim run --mcap OUT.mcap`: an offline run recorded as locd would have seen it live, in the
// layout of `locctl record` (locd_mcap's LocdWriter): the session request with the scenario's
// plugin config, the initial pose, every sensor message, every pose, the diagnostics (particles),
// maps and grids the plugin published, and the ground truth at each odometry stamp
// (locd/ground_truth). Log times are the simulated stamps. Foxglove opens it; locsim replay
// --offline replays it.
#pragma once

#include <memory>
#include <string>

#include "locd/mcap/locd_writer.hpp"
#include "locd/sim/offline_runner.hpp"

namespace locd::sim {

class McapRunRecording : public RunObserver {
 public:
  McapRunRecording(const std::string& path, const Scenario& scenario);
  void started(const PoseEstimate& initial_pose) override;
  void measurement(const Measurement& m, const Pose2& truth) override;
  void updated(const UpdateResult& update, double update_ms) override;
  void close() { out_.writer().close(); }

 private:
  mcap::LocdWriter out_;
  std::string robot_id_, plugin_, config_text_;
  int64_t last_stamp_ = 0;
};

}  // namespace locd::sim
