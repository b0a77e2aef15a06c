// The icp_explorer pipeline for one robot: stop, scan, register the scan to the model with the
// modified ICP (odometry prediction + bounded-error rejection), add it to the voxel model and to
// the layered hexahedral map, and pick the next scan position. Plain sdk types in, plain results
// out; the plugin only copies parameters into IcpExplorerConfig (config.hpp).
//
// Uncertainty: the map is anchored at the first scan (the pose set_pose gave); covariances are
// kept as left perturbations xi = (v, omega) about the map origin (T_true = exp(xi) T). Before a
// scan, the prior is the last scan's covariance plus one odometry leg's (each odometry_bound
// taken as a uniform error: sigma = bound / sqrt(3)). After registration, the covariance is
//   the registration's own (sigma^2 H^+ on the well-constrained directions)
// + the model's: the scans whose voxels the correspondences used carry their own covariance into
//   this pose, A_s = M_s S_s M_s^T with M_s = H^+ H_s (the part of the solution scan s's voxels
//   determine), summed as (sum_s c_s) sum_s A_s / c_s, c_s = sqrt(tr A_s): a bound for any
//   correlation between the scans (Cauchy-Schwarz), tight when one scan dominates
// + the prior's, along the poorly constrained directions (held to odometry)
// + a floor: a tenth of a map voxel of RMS point motion in every direction (the model's resolution).
// States (and the map): converged (RegistrationResult::converged) -> tracking; fits but not
// converged -> uncertain (both extend the map); does not fit -> lost, the odometry prediction with
// the prior's covariance, the map unchanged.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "locd/icp_explorer/config.hpp"
#include "locd/icp_explorer/correspondence_rejection.hpp"
#include "locd/icp_explorer/layered_hexahedral_map.hpp"
#include "locd/icp_explorer/modified_icp.hpp"
#include "locd/icp_explorer/next_best_view.hpp"
#include "locd/icp_explorer/voxel_map.hpp"
#include "locd/sdk/types.hpp"

namespace locd::icp_explorer {

struct ScanOutcome {
  Eigen::Isometry3d T_map_base = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_map_base_predicted = Eigen::Isometry3d::Identity();
  Matrix6d covariance = Matrix6d::Identity();  // over (x, y, z, roll, pitch, yaw), small-angle
  bool registered = false;                      // false for the first scan (nothing to register to)
  RegistrationResult registration;
  std::optional<ExplorationDecision> exploration;
  size_t input_points = 0;
  size_t non_finite_points = 0;                 // dropped
  size_t source_points = 0;                     // after downsampling
  size_t carved_voxels = 0;                     // model voxels this scan saw through (ghosts)
  bool intensity_missing = false;               // rule (a) was off for this scan
  bool added_to_model = false;                  // false when the scan did not fit (state lost)
  LocalizationAssessment localization;          // from the registration's criteria (README)
  double preprocess_ms = 0.0, registration_ms = 0.0, model_update_ms = 0.0, planning_ms = 0.0;
};

class IcpExplorer {
 public:
  explicit IcpExplorer(const IcpExplorerConfig& config);

  // pose_covariance over (x, y, z, roll, pitch, yaw): ignored before the first scan (the pose
  // anchors the map), the pose's uncertainty within the map after it.
  void set_pose(const Eigen::Isometry3d& T_map_base, const Matrix6d& pose_covariance = Matrix6d::Zero());
  void add_odometry(const Odometry& odometry);
  // A cloud the server has validated (locd/sdk/validate.hpp); NaN points are skipped and
  // counted. Throws InputError for a cloud above max_points.
  ScanOutcome add_scan(const PointCloud& cloud);

  // The scan pose odometry predicts now (last registered pose + odometry since).
  Eigen::Isometry3d predicted_pose() const;

  const IcpExplorerConfig& config() const { return config_; }
  const VoxelMap& model() const { return model_; }
  const LayeredHexahedralMap& layered_map() const { return layered_map_; }
  const std::vector<Eigen::Vector2d>& scan_positions() const { return scan_positions_; }
  size_t scans() const { return scans_; }
  // The intensity scale in use: config's, or estimated from the first cloud with intensity (the
  // next of 1, 255, 65535 at or above its largest intensity; larger still: that largest value);
  // 0 until then.
  double intensity_scale() const { return intensity_scale_; }
  // Covariance of the last scan pose, xi about the map origin.
  const Matrix6d& covariance_xi() const { return covariance_xi_; }
  // The prior's covariance for the next scan (last + one odometry leg), xi about the map origin.
  Matrix6d prior_covariance_xi() const;

  // (x, y, z, roll, pitch, yaw) covariance of a pose from its xi covariance, and back.
  static Matrix6d pose_covariance(const Matrix6d& covariance_xi, const Eigen::Isometry3d& T_map_base);
  static Matrix6d xi_covariance(const Matrix6d& pose_covariance, const Eigen::Isometry3d& T_map_base);

 private:
  Matrix6d model_covariance(const RegistrationResult& r) const;

  IcpExplorerConfig config_;
  VoxelMap model_;
  LayeredHexahedralMap layered_map_;
  NextBestViewPlanner planner_;
  Eigen::Isometry3d T_map_base_last_ = Eigen::Isometry3d::Identity();
  std::optional<Eigen::Isometry3d> odom_latest_;
  std::optional<Eigen::Isometry3d> odom_at_last_;
  std::vector<Eigen::Vector2d> scan_positions_;
  size_t scans_ = 0;
  VoxelMap coarse_model_;
  double intensity_scale_ = 0.0;
  Matrix6d covariance_xi_ = Matrix6d::Zero();
  std::vector<Matrix6d> insert_covariance_;  // per model insert (VoxelMap::first_insert), xi
};

}  // namespace locd::icp_explorer
