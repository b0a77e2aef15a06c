// grid_mcl's Localizer: thin I/O around the core. Odometry is kept by stamp (the sdk's
// PoseHistory) and carries the pose between filter updates; a scan runs the filter (when the robot
// moved enough) with the odometry interpolated at the scan's stamp and returns the pose with
// covariance, the diagnostics, a subsample of the particles and the localization state; the map
// goes out once as the "occupancy" grid layer.
//
// Measurements come in stamp order, so the odometry just after a scan arrives after it: a scan
// newer than the newest odometry waits (one scan at most) until odometry at or after its stamp
// arrives, and runs then; a second scan arriving first runs the waiting one with the newest
// odometry (never extrapolated). Without any odometry a scan runs at once (odometry: identity).
#pragma once

#include <memory>
#include <optional>

#include "locd/grid_mcl/grid_particle_filter.hpp"
#include "locd/sdk/pose_history.hpp"
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
  // Runs the filter on a scan with the odometry at its stamp; the localization state and the
  // diagnostics go into `result`.
  void correct(const LaserScan& scan, UpdateResult& result);
  Pose2 odometry_at(int64_t stamp_ns) const;
  std::optional<PoseEstimate> make_estimate(const Header& header) const;

  Config config_;
  std::unique_ptr<GridParticleFilter> filter_;
  PoseHistory odometry_;                 // odom frame, by stamp
  std::optional<LaserScan> waiting_;     // a scan newer than the newest odometry
  bool state_reported_ = false;          // since the last (re)start
};

}  // namespace locd::grid_mcl
