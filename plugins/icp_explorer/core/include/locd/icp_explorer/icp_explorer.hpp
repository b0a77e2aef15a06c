// The icp_explorer pipeline for one robot: stop, scan, register the scan to the model with the
// modified ICP (odometry prediction + bounded-error rejection), add it to the voxel model and to
// the layered hexahedral map, and pick the next scan position. Plain sdk types in, plain results
// out; the plugin only copies parameters into IcpExplorerConfig (config.hpp).
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
  double preprocess_ms = 0.0, registration_ms = 0.0, model_update_ms = 0.0, planning_ms = 0.0;
};

class IcpExplorer {
 public:
  explicit IcpExplorer(const IcpExplorerConfig& config);

  void set_pose(const Eigen::Isometry3d& T_map_base);
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

 private:
  IcpExplorerConfig config_;
  VoxelMap model_;
  LayeredHexahedralMap layered_map_;
  NextBestViewPlanner planner_;
  Eigen::Isometry3d T_map_base_last_ = Eigen::Isometry3d::Identity();
  std::optional<Eigen::Isometry3d> odom_latest_;
  std::optional<Eigen::Isometry3d> odom_at_last_;
  std::vector<Eigen::Vector2d> scan_positions_;
  size_t scans_ = 0;
};

}  // namespace locd::icp_explorer
