// grid_mcl's Localizer: thin I/O around the core. Odometry is remembered and carries the pose
// between filter updates; a scan runs the filter (when the robot moved enough) and returns the
// pose with covariance, the diagnostics, a subsample of the particles and the localization
// state; the map goes out once as the "occupancy" grid layer.
#pragma once

#include <memory>
#include <optional>

#include "locd/grid_mcl/grid_particle_filter.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::grid_mcl {

class GridMclLocalizer : public Localizer {
 public:
  void configure(const PluginContext& context, const Params& params) override;
  void set_pose(const PoseEstimate& pose) override;
  UpdateResult update(const Measurement& measurement) override;
  UpdateResult initial_outputs() const override;

  const GridParticleFilter& filter() const { return *filter_; }

 private:
  UpdateResult on_scan(const LaserScan& scan);
  std::optional<PoseEstimate> make_estimate(const Header& header) const;

  Config config_;
  std::unique_ptr<GridParticleFilter> filter_;
  Pose2 odometry_;  // the latest, odom frame (identity until odometry arrives)
};

}  // namespace locd::grid_mcl
