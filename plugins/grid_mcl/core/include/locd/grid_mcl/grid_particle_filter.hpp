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
//   hypothesis test           uncertain for hypothesis_test_after_uncertain_updates (a leaky
//                             count) with the estimate failing the fit or see-through test:
//                             candidates over the free cells, the best refined; those far away
//                             that pass both are followed; the only one left after
//                             hypothesis_confirm_updates updates takes the filter there
//                             (kidnapped along look-alike corridors)
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
  double known = 0.0;                  // share of the hits that fit counts (the map knows their end)
  bool misfit = false;                 // fit below tracking_min_fit where the map can judge the
                                       // scan (known >= tracking_min_known): what relocalizes
  double see_through = 0.0;            // share of the scan's returns passing through the map's walls
  double sigma_hit = 0.0;              // the field's width this update (search_sigma_hit)
  bool relocalized = false;            // lost too long: global localization restarted, or the
                                       // filter moved to a confirmed hypothesis
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
  // `dense`: the scan's see_through_beams beams (empty when the see-through check is off).
  void assess(const PreparedScan& scan, const PreparedScan& dense, CorrectionReport& report);
  // The hypothesis test (FilterConfig::hypothesis_test_after_uncertain_updates): the pose to move
  // to once a hypothesis is confirmed.
  std::optional<Pose2> follow_hypotheses(const PreparedScan& scan, const PreparedScan& dense, const CorrectionReport& report);
  // A candidate that passes both tracking tests, is at least cluster_radius from the estimate and
  // fits no worse than it, refined; none: no such candidate.
  std::optional<Pose2> checked(const Pose2& candidate, const PreparedScan& scan, const PreparedScan& dense,
                               double estimate_fit) const;
  // Coarse-to-fine hill climbing on the beams' closeness to the map's obstacles.
  Pose2 refine(const Pose2& pose, const PreparedScan& scan) const;

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
  int uncertain_updates_ = 0;  // leaky count of updates not tracking (the hypothesis test)
  struct Hypothesis {
    Pose2 pose;                // carried by the odometry like the estimate
    int confirmations = 0;     // updates it passed since it was found
  };
  std::vector<Hypothesis> hypotheses_;  // at most kMaxHypotheses, pairwise distinct
  static constexpr size_t kMaxHypotheses = 8;
  LocalizationAssessment assessment_{LocalizationState::kLost, "no pose yet"};
};

}  // namespace locd::grid_mcl
