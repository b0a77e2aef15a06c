// The modified ICP's correspondence rejection (paper section 2.1). A correspondence pairs a
// data point p (base_link frame of the new scan) with a model point q (map frame). With
// T_odom = the scan pose predicted from odometry and the odometry error bounded per leg, it is
// rejected when
//  (a) |intensity(p) - intensity(q)| > intensity_threshold;
//  (b) q lies outside the overlap region: farther than max_range + the translation bound from
//      the predicted scanner position, so no pose within the bounds could have seen it;
//  (c) the error vector e = q - T_odom p is longer than the largest displacement a pose error
//      within the bounds can give p: |t_bound| + chord(yaw bound) * r_xy(p) + tilt * |p| + margin;
//  (d) e points where no pose error within the bounds can move p: expressed in the predicted
//      base frame, e must be a box translation (forward, lateral, vertical bounds) plus a yaw
//      arc along the tangent of p (small-angle), each widened by margin.
// Each rule can be switched off.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>

#include "locd/icp_explorer/config.hpp"

namespace locd::icp_explorer {

enum class Rejection : int { kAccepted = 0, kIntensity, kOverlap, kErrorLength, kErrorDirection };
constexpr size_t kRejectionKinds = 5;
const char* rejection_name(Rejection r);  // "accepted", "intensity", "overlap", ...

class CorrespondenceRejector {
 public:
  // T_map_base_predicted: the scan pose from odometry; sensor_in_base: the scanner on the robot.
  CorrespondenceRejector(const RejectionRules& rules, const OdometryErrorBound& bound,
                         const Eigen::Isometry3d& T_map_base_predicted, const Eigen::Isometry3d& sensor_in_base);

  // Intensities may be NaN (unknown): rule (a) then lets the pair through.
  Rejection check(const Eigen::Vector3d& point_in_base, float point_intensity, const Eigen::Vector3d& model_point,
                  float model_intensity) const;

  bool intensity_consistent(float point_intensity, float model_intensity) const;
  bool in_overlap_region(const Eigen::Vector3d& model_point) const;
  double max_error_length(const Eigen::Vector3d& point_in_base) const;
  bool error_direction_possible(const Eigen::Vector3d& point_in_base, const Eigen::Vector3d& model_point) const;

  const RejectionRules& rules() const { return rules_; }
  const Eigen::Vector3d& sensor_in_base() const { return sensor_in_base_; }
  // Switches rule (a) off for scans without intensity.
  void disable_intensity() { rules_.intensity = false; }
  // The same rules with the margin widened by `extra` (m): for coarse voxels, whose centroids
  // stand off the surfaces by up to half a voxel.
  CorrespondenceRejector widened(double extra) const;

 private:
  RejectionRules rules_;
  OdometryErrorBound bound_;
  Eigen::Isometry3d sensor_pose_;
  Eigen::Isometry3d T_map_base_;
  Eigen::Isometry3d T_base_map_;
  Eigen::Vector3d sensor_in_map_;
  Eigen::Vector3d sensor_in_base_;
  double overlap_radius2_;
  double translation_bound_;
  double chord_per_metre_;
  double sin_tilt_;
};

}  // namespace locd::icp_explorer
