// emoi_markov's Localizer: thin I/O around EmoiMarkovFilter (the core). Odometry returns the
// current estimate, IMU only sets the attitude, a scan or cloud returns the pose, the belief grid
// and diagnostics when it triggered a sensor update.
#pragma once

#include <memory>

#include "locd/emoi_markov/emoi_markov_filter.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::emoi {

class EmoiMarkovLocalizer : public Localizer {
 public:
  void configure(const PluginContext& context, const Params& params) override;
  void set_pose(const PoseEstimate& pose) override;
  UpdateResult update(const Measurement& measurement) override;
  UpdateResult initial_outputs() const override;

  // Same as configure, for programs that hold the config and the DSM already (simulator, bench).
  void configure(const PluginContext& context, const EmoiMarkovConfig& config, ElevationMap dsm);
  // The filter, for programs that look inside (tests, the four-position experiment).
  const EmoiMarkovFilter& filter() const;

 private:
  UpdateResult sensor_update_result(int64_t stamp_ns, const std::optional<FilterUpdateReport>& report) const;
  std::unique_ptr<EmoiMarkovFilter> filter_;
};

}  // namespace locd::emoi
