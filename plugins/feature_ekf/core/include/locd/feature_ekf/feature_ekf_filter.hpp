// The paper's localizer composed from its pieces: odometry predicts (eq. 4-6), a scan is turned
// into features, associated with the map (eq. 8-12) and fused by sequential EKF updates
// (eq. 13-14). No I/O here: the plugin copies parameters into FeatureEkfConfig (config.hpp).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "locd/feature_ekf/extended_kalman_filter.hpp"
#include "locd/feature_ekf/laser_feature_extractor.hpp"
#include "locd/feature_ekf/nearest_neighbor_association.hpp"
#include "locd/feature_ekf/odometry_motion_model.hpp"
#include "locd/sdk/feature_map.hpp"
#include "locd/sdk/geometry.hpp"

namespace locd::feature_ekf {

struct ScanUpdateReport {
  ExtractedFeatures features;
  std::vector<Association> associations;  // one per extracted feature
  size_t matched[3] = {0, 0, 0};          // applied updates per FeatureKind
  double mean_nis = 0.0;                  // mean normalized innovation squared of applied updates
  std::vector<double> nis;                // of each applied update (2 dof), against the predicted state
};

class FeatureEkfFilter {
 public:
  using Filter = ExtendedKalmanFilter<3>;

  FeatureEkfFilter(FeatureEkfConfig config, FeatureMap2D map);

  void set_pose(const Eigen::Vector3d& pose, const Eigen::Matrix3d& covariance);

  // Odometry pose (odom frame) at a stamp; from the second message on, predicts with the control
  // between the two. Returns true when it predicted; a stamp not after the previous one (or a gap
  // above max_odometry_gap) only restarts the odometry.
  bool apply_odometry(const Pose2& odometry_pose, int64_t stamp_ns);

  // Extraction, association and update.
  ScanUpdateReport update(const LaserScan& scan);
  // Association and update of already extracted features.
  ScanUpdateReport update(ExtractedFeatures features);

  // The same steps on another state (the relocalization's hypotheses): prediction with a control,
  // association and update of extracted features (the report's `features` stays empty).
  void predict(Filter& filter, const MotionControl& u) const;
  ScanUpdateReport correct(Filter& filter, const ExtractedFeatures& features) const;
  // The control of the last odometry message that predicted (none after a restart of odometry).
  const std::optional<MotionControl>& last_control() const { return last_control_; }

  Eigen::Vector3d pose() const { return filter_.state(); }
  Eigen::Matrix3d covariance() const { return filter_.covariance(); }
  const FeatureMap2D& map() const { return map_; }
  const FeatureEkfConfig& config() const { return config_; }
  const LaserFeatureExtractor& extractor() const { return extractor_; }
  const NearestNeighborAssociation& association() const { return association_; }

 private:
  // Raises the position covariance to position_stddev_floor^2 along each principal direction and
  // the heading variance to heading_stddev_floor^2 (adding a positive semi-definite matrix).
  void apply_covariance_floor(Filter& filter) const;

  FeatureEkfConfig config_;
  FeatureMap2D map_;
  OdometryMotionModel motion_model_;
  LaserFeatureExtractor extractor_;
  NearestNeighborAssociation association_;
  Filter filter_;
  std::optional<Pose2> last_odometry_pose_;
  std::optional<MotionControl> last_control_;
  int64_t last_odometry_stamp_ns_ = 0;
};

}  // namespace locd::feature_ekf
