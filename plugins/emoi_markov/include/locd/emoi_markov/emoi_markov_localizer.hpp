// The emoi_markov localizer: DSM + precomputed EMOI layers, a local elevation map built from
// scans/clouds with odometry and IMU attitude, and the Markov grid. Every `update_distance_m`
// of travel it applies the motion update for the odometry since the last one, computes the
// robot's EMOI over its observed cells and applies the sensor update.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "locd/emoi_markov/dsm_io.hpp"
#include "locd/emoi_markov/local_elevation_map.hpp"
#include "locd/emoi_markov/markov_grid.hpp"
#include "locd/emoi_markov/masked_emoi.hpp"
#include "locd/emoi_markov/odometry_distortion.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::emoi {

struct EmoiMarkovConfig {
  std::string map;                                 // DSM name, resolved by PluginContext::maps
  std::vector<double> radii_m{5.0, 10.0, 15.0};
  SensorModelConfig sensor;
  std::string sensor_model = "masked";             // "masked" (observed cells only) or "full_disk" (paper)
  double match_resolution_m = 0.5;                 // matching grid of the masked model
  double odometry_error = 0.1;                     // blur stddev per metre travelled; also the scale error
  DistortionConfig distortion;                     // odometry distortion hypotheses (scale_stddev = odometry_error)
  double min_blur_m = 0.0;                         // added (in quadrature) to every motion blur
  double update_distance_m = 10.0;                 // travel between sensor updates
  std::string heading_source = "odometry";         // "odometry" (+ offset from set_pose) or "imu"
  bool use_initial_pose = false;                   // false: global localization (uniform belief)
  double base_height_m = 0.0;                      // base_link above the ground
  LocalMapConfig local_map;                        // resolution = the DSM's
  bool cache = true;                               // EMOI layers cached on disk
  size_t belief_output_max_cells = 250'000;        // belief diagnostics grid is pooled to this
};

// Reads and validates every parameter (ranges in the messages). Unknown keys are an error.
EmoiMarkovConfig parse_config(const Params& params);

class EmoiMarkovLocalizer : public Localizer {
 public:
  void configure(const PluginContext& context, const Params& params) override;
  void set_pose(const PoseEstimate& pose) override;
  UpdateResult update(const Measurement& measurement) override;
  UpdateResult initial_outputs() const override;

  // Same as configure, for programs that hold the config and the DSM already (simulator, bench).
  void configure(const PluginContext& context, const EmoiMarkovConfig& config, ElevationMap dsm);

  const MarkovGrid& grid() const { return *grid_; }
  const LocalElevationMap& local_map() const { return *local_map_; }
  const EmoiMarkovConfig& config() const { return config_; }
  const DistortionReport& last_distortion() const { return distortion_; }
  size_t sensor_updates() const { return sensor_updates_; }
  bool layers_from_cache() const { return layers_from_cache_; }
  const EmoiLayers* full_disk_layers() const { return layers_ ? &*layers_ : nullptr; }
  const MaskedEmoiMatcher* matcher() const { return matcher_.get(); }
  // The masked model's last match (DSM EMOI_M on the matching grid; with the sparse model only on
  // the support, NaN elsewhere), for diagnostics.
  const std::optional<MaskedEmoiMatcher::Match>& last_match() const { return last_match_; }

 private:
  UpdateResult on_odometry(const Odometry& odometry);
  UpdateResult on_imu(const Imu& imu);
  UpdateResult on_scan(const LaserScan& scan);
  UpdateResult on_cloud(const PointCloud& cloud);
  UpdateResult after_insert(int64_t stamp_ns);
  // p(z|x) on the DSM grid: `values` on `window`, `outside` everywhere else.
  struct WindowLikelihood {
    cv::Mat_<float> values;
    cv::Rect window;
    float outside = 0.0f;
  };
  // The masked likelihood. With distortion hypotheses and a concentrated prior, the sparse model:
  // L_mix on the cells holding the prior's mass, one value elsewhere, no whole-map DFT match
  // (odometry_distortion.hpp); otherwise the DFT match on the whole map. previous_coarse: the
  // belief before the motion update on the matching grid (empty: no hypotheses); shift, travel,
  // blur: that motion update's.
  WindowLikelihood masked_likelihood(const cv::Mat_<float>& previous_coarse, const Eigen::Vector2d& shift,
                                     double travel, double blur, std::vector<double>& weights);
  Eigen::Isometry3d base_in_odom() const;
  double map_heading() const;
  PoseEstimate estimate(int64_t stamp_ns) const;
  GridLayer belief_layer() const;

  PluginContext context_;
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

  std::optional<Odometry> last_odometry_;
  std::optional<Eigen::Quaterniond> imu_orientation_;
  double yaw_offset_ = 0.0;                       // map yaw - odom yaw
  std::optional<double> pending_set_pose_yaw_;    // applied at the next odometry
  Eigen::Vector2d pending_shift_ = Eigen::Vector2d::Zero();  // map frame, since the last update
  double pending_travel_m_ = 0.0;
  double travelled_m_ = 0.0;
  BeliefSummary summary_;
  size_t sensor_updates_ = 0;
  size_t rejected_points_ = 0;
  size_t belief_resets_ = 0;
  double last_mass_lost_ = 0.0;
  std::vector<PointEmoi> last_robot_emoi_;
  int64_t last_stamp_ns_ = 0;
};

}  // namespace locd::emoi
