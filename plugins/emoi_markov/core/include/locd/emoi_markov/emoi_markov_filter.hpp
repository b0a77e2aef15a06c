// The emoi_markov filter (the paper's Table 1): a DSM with its EMOI layers (full-disk model) or
// matcher (masked model), a local elevation map built from scans or clouds with odometry and IMU
// attitude, and the Markov grid. Every `update_distance_m` of travel it applies the motion update
// for the odometry since the last one, computes the robot's EMOI over its observed cells and
// applies the sensor update. No Localizer and no parameters here: plugin/ wraps it.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "locd/emoi_markov/belief_assessment.hpp"
#include "locd/emoi_markov/config.hpp"
#include "locd/emoi_markov/dsm_io.hpp"
#include "locd/emoi_markov/local_elevation_map.hpp"
#include "locd/emoi_markov/markov_grid.hpp"
#include "locd/emoi_markov/masked_emoi.hpp"
#include "locd/emoi_markov/odometry_distortion.hpp"
#include "locd/sdk/types.hpp"

namespace locd::emoi {

// What one sensor update did (Table 1 once): the motion update, the robot's EMOI per radius and
// the weights the sensor model gave them, the distortion hypotheses' posterior, the sensor update.
struct FilterUpdateReport {
  MotionUpdateReport motion;
  SensorUpdateReport sensor;
  std::vector<PointEmoi> robot_emoi;   // per radius
  std::vector<double> weights;         // per radius
  DistortionReport distortion;
};

class EmoiMarkovFilter {
 public:
  // The DSM's EMOI layers (full_disk) come from the on-disk cache when config.cache, else are
  // computed with progress reports. Throws ConfigError when the DSM has more than max_map_cells
  // cells or a radius does not fit in it.
  EmoiMarkovFilter(const EmoiMarkovConfig& config, ElevationMap dsm, size_t max_map_cells,
                   const ProgressCallback& progress = {});

  // Throws InputError for an initial pose outside the DSM.
  void set_pose(const PoseEstimate& pose);
  void add_odometry(const Odometry& odometry);
  void add_imu(const Imu& imu);
  // Insert into the local map; the sensor update runs once update_distance_m has been travelled
  // since the last one. Throws InputError before any odometry (the map needs the robot's pose).
  std::optional<FilterUpdateReport> add_scan(const LaserScan& scan);
  std::optional<FilterUpdateReport> add_cloud(const PointCloud& cloud);

  // The belief's mode (shifted by the odometry since the last update), its covariance widened
  // by the drift since, attitude from the IMU, height from the DSM.
  PoseEstimate estimate(int64_t stamp_ns) const;
  // The belief, pooled to at most belief_output_max_cells cells.
  GridLayer belief_layer() const;

  const MarkovGrid& grid() const { return *grid_; }
  const LocalElevationMap& local_map() const { return *local_map_; }
  const EmoiMarkovConfig& config() const { return config_; }
  const DistortionReport& last_distortion() const { return distortion_; }
  const BeliefSummary& summary() const { return summary_; }
  // The localization state and its criteria (belief_assessment.hpp), judged after every sensor
  // update; before the first one: lost (the global belief, or the initial pose not yet checked).
  const BeliefAssessment& assessment() const { return assessment_; }
  size_t sensor_updates() const { return sensor_updates_; }
  size_t rejected_points() const { return rejected_points_; }
  size_t belief_resets() const { return belief_resets_; }
  bool layers_from_cache() const { return layers_from_cache_; }
  const std::string& layers_key() const { return layers_key_; }
  const EmoiLayers* full_disk_layers() const { return layers_ ? &*layers_ : nullptr; }
  const MaskedEmoiMatcher* matcher() const { return matcher_.get(); }
  // The masked model's last match (DSM EMOI_M on the matching grid; with the sparse model only on
  // the support, NaN elsewhere), for diagnostics.
  const std::optional<MaskedEmoiMatcher::Match>& last_match() const { return last_match_; }

 private:
  // p(z|x) on the DSM grid: `values` on `window`, `outside` everywhere else.
  struct WindowLikelihood {
    cv::Mat_<float> values;
    cv::Rect window;
    float outside = 0.0f;
  };
  // Inserts into the local map (after the checks and the map's move), then after_insert.
  std::optional<FilterUpdateReport> insert(
      const char* what, const std::function<InsertStatistics(const Eigen::Isometry3d& base_in_odom)>& into_local_map);
  std::optional<FilterUpdateReport> after_insert();
  // Table 1, perception with the masked model. With distortion hypotheses and a concentrated
  // prior, the sparse model: L_mix on the cells holding the prior's mass, one value elsewhere, no
  // whole-map DFT match (odometry_distortion.hpp); otherwise the DFT match on the whole map.
  // previous_coarse: the belief before the motion update on the matching grid (empty: no
  // hypotheses); shift, travel, blur: that motion update's.
  WindowLikelihood masked_likelihood(const cv::Mat_<float>& previous_coarse, const Eigen::Vector2d& shift,
                                     double travel, double blur, std::vector<double>& weights);
  // The full-disk model (the paper's): log p(z|x) on the DSM grid.
  cv::Mat_<float> full_disk_log_likelihood_now(std::vector<double>& weights);
  Eigen::Isometry3d base_in_odom() const;
  // The last sparse update's fit (RMS shape residual, m) at the matching cell holding `position`;
  // NaN when not computed there.
  double fit_at(const Eigen::Vector2d& position) const;
  double map_heading() const;

  EmoiMarkovConfig config_;
  std::unique_ptr<MarkovGrid> grid_;
  std::unique_ptr<LocalElevationMap> local_map_;
  std::optional<EmoiLayers> layers_;               // full_disk model
  std::unique_ptr<MaskedEmoiMatcher> matcher_;     // masked model
  std::optional<MaskedEmoiMatcher::Match> last_match_;
  std::vector<DistortionHypothesis> hypotheses_;
  DistortionReport distortion_;                    // the last sensor update's
  cv::Mat_<float> dsm_elevation_;
  bool layers_from_cache_ = false;
  std::string layers_key_;

  std::optional<Odometry> last_odometry_;
  std::optional<Eigen::Quaterniond> imu_orientation_;
  double yaw_offset_ = 0.0;                       // map yaw - odom yaw
  std::optional<double> pending_set_pose_yaw_;    // applied at the next odometry
  Eigen::Vector2d pending_shift_ = Eigen::Vector2d::Zero();  // map frame, since the last update
  double pending_travel_m_ = 0.0;
  double travelled_m_ = 0.0;
  BeliefSummary summary_;
  BeliefAssessment assessment_;
  // The last sparse update's support (matching cells) and best shape residual per cell: the fit
  // at the estimate (BeliefAssessment::fit_rms_m); empty after a global update.
  std::vector<cv::Point> fit_cells_;
  std::vector<float> fit_residual_;
  size_t sensor_updates_ = 0;
  size_t rejected_points_ = 0;
  size_t belief_resets_ = 0;
  std::vector<PointEmoi> last_robot_emoi_;
};

}  // namespace locd::emoi
