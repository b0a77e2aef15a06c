// Monte Carlo localization on an occupancy grid, as AMCL runs it (Probabilistic Robotics Table
// 8.2 with KLD sampling, Fox 2003, and augmented MCL, Table 8.3), composed of the sdk's
// particle-filter core and this plugin's motion and laser models:
//
//   correct(scan, odometry)   when the odometry moved update_min_d or turned update_min_a since
//                             the last filter update (or the filter was just (re)started):
//                               sample the motion of every particle        (motion_models.hpp)
//                               weight by the laser model                  (laser_models.hpp)
//                               update w_slow, w_fast                      (AugmentedMclRecovery)
//                               every resample_interval-th update: low-variance resampling to the
//                               KLD count, injecting max(0, 1 - w_fast / w_slow) of the set
//                               uniformly over the free cells              (kld_resample)
//                             then the estimate (main_cluster) and the localization state
//   set_pose / set_global     a Gaussian cloud, or global localization: global_particles poses
//                             drawn uniformly over the free cells
//   relocalization            one pose held (main cluster mass) but a scan fit below
//                             tracking_min_fit for relocalize_after_lost_updates updates
//                             (kidnapped, or a search settled wrong): global localization again
//
// Between filter updates the pose follows the odometry: estimate_at(odom) composes the last
// estimate with the odometry increment since that update.
#pragma once

#include <memory>
#include <optional>
#include <random>
#include <vector>

#include "locd/grid_mcl/config.hpp"
#include "locd/grid_mcl/laser_models.hpp"
#include "locd/grid_mcl/motion_models.hpp"
#include "locd/grid_mcl/shared_map.hpp"
#include "locd/sdk/particle_filter.hpp"
#include "locd/sdk/types.hpp"

namespace locd::grid_mcl {

class WeightingPool;

struct CorrectionReport {
  bool updated = false;          // the filter ran on this scan
  bool resampled = false;
  size_t beams = 0;              // beams used (hits)
  size_t injected = 0;
  double injection_probability = 0.0;
  double effective_sample_size = 0.0;  // before resampling
  double average_likelihood = 0.0;     // prior-weighted mean pz per beam (w_slow/w_fast input)
  double fit = 0.0;                    // the state's scan fit at the estimate
  double see_through = 0.0;            // share of the scan's returns passing through the map's walls
  double sigma_hit = 0.0;              // the field's width this update (search_sigma_hit)
  bool relocalized = false;            // lost too long: global localization restarted
};

class GridParticleFilter {
 public:
  GridParticleFilter(const Config& config, std::shared_ptr<const SharedMap> map);
  ~GridParticleFilter();

  void set_pose(const Pose2& mean, const Eigen::Matrix3d& covariance);
  void set_global();
  bool initialized() const { return !particles_.empty(); }

  // One scan with the odometry pose at its stamp (odom frame).
  CorrectionReport correct(const LaserScan& scan, const Pose2& odometry);

  // The estimate at the last filter update, and carried to `odometry` by the odometry increment.
  std::optional<ParticleCluster> estimate() const;
  std::optional<ParticleCluster> estimate_at(const Pose2& odometry) const;
  const LocalizationAssessment& assessment() const { return assessment_; }

  const std::vector<PoseParticle>& particles() const { return particles_; }
  const AugmentedMclRecovery& recovery() const { return recovery_; }
  const Config& config() const { return config_; }
  const SharedMap& map() const { return *map_; }
  // Heap bytes this filter holds beyond the shared map (particles and buffers).
  size_t memory_bytes() const;

  // Poses uniformly over the free cells (the global start and the injection proposal).
  void sample_free_poses(size_t count, std::vector<PoseParticle>& out);

 private:
  void weigh(const PreparedScan& scan, CorrectionReport& report);
  void assess(const PreparedScan& scan, const LaserScan& raw, CorrectionReport& report);

  Config config_;
  std::shared_ptr<const SharedMap> map_;
  MotionModel motion_;
  LaserModel laser_;
  std::vector<PoseParticle> particles_;
  std::vector<double> factors_, measures_;
  std::mt19937_64 rng_;
  KldResampling kld_;
  PoseBinCounter bins_;
  AugmentedMclRecovery recovery_;
  std::unique_ptr<WeightingPool> pool_;
  std::optional<Pose2> odometry_at_update_;  // none: the next scan updates (after a (re)start)
  std::optional<ParticleCluster> estimate_;
  int updates_since_resampling_ = 0;
  int lost_updates_ = 0;    // consecutive updates with a scan fit below tracking_min_fit
  LocalizationAssessment assessment_{LocalizationState::kLost, "no pose yet"};
};

}  // namespace locd::grid_mcl
