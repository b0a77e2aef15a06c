#include "locd/icp_explorer/icp_explorer.hpp"

#include <chrono>
#include <cmath>
#include <string>

#include "locd/sdk/errors.hpp"

namespace locd::icp_explorer {

namespace {
double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace

IcpExplorer::IcpExplorer(const IcpExplorerConfig& config)
    : config_(config),
      model_(config.map_voxel_size, config.normal_neighbours),
      layered_map_(config.layered_map),
      planner_(config.planner) {}

void IcpExplorer::set_pose(const Eigen::Isometry3d& T_map_base) {
  T_map_base_last_ = T_map_base;
  odom_at_last_ = odom_latest_;
}

void IcpExplorer::add_odometry(const Odometry& odometry) {
  odom_latest_ = odometry.pose;
  if (!odom_at_last_) odom_at_last_ = odometry.pose;
}

Eigen::Isometry3d IcpExplorer::predicted_pose() const {
  if (!odom_latest_ || !odom_at_last_) return T_map_base_last_;
  return T_map_base_last_ * (odom_at_last_->inverse() * *odom_latest_);
}

ScanOutcome IcpExplorer::add_scan(const PointCloud& cloud) {
  ScanOutcome out;
  out.input_points = cloud.points.size();
  if (cloud.points.size() > config_.max_points)
    throw InputError("cloud: " + std::to_string(cloud.points.size()) + " points exceed the limit of " +
                     std::to_string(config_.max_points) + " (icp_explorer.max_points)");
  for (const auto& p : cloud.points) out.non_finite_points += !p.allFinite();
  out.intensity_missing = cloud.intensity.empty();

  auto start = std::chrono::steady_clock::now();
  const ScanPoints source = voxel_downsample(cloud.points, cloud.intensity, config_.scan_voxel_size, cloud.sensor_pose);
  const ScanPoints dense = voxel_downsample(cloud.points, cloud.intensity, config_.map_voxel_size, cloud.sensor_pose);
  out.source_points = source.size();
  out.preprocess_ms = ms_since(start);

  out.T_map_base_predicted = predicted_pose();
  out.T_map_base = out.T_map_base_predicted;
  if (!model_.empty()) {
    start = std::chrono::steady_clock::now();
    CorrespondenceRejector rejector(config_.rejection, config_.odometry_bound, out.T_map_base_predicted,
                                    cloud.sensor_pose);
    if (out.intensity_missing) rejector.disable_intensity();
    out.registration = register_scan(source, model_, out.T_map_base_predicted, rejector, config_.icp);
    out.registration_ms = ms_since(start);
    out.T_map_base = out.registration.T_map_base;
    out.registered = true;
    // Covariance of xi (left perturbation), mapped to (position, rotation): dt = v - [t]x w.
    const double sigma2 = std::max(out.registration.rms_error * out.registration.rms_error, 1e-6);
    Eigen::FullPivLU<Matrix6d> lu(out.registration.information);
    if (lu.isInvertible()) {
      Matrix6d A = Matrix6d::Identity();
      A.block<3, 3>(0, 3) = -skew(out.T_map_base.translation());
      out.covariance = A * (sigma2 * lu.inverse()) * A.transpose();
    } else {
      out.covariance = Matrix6d::Identity();
    }
  } else {
    out.covariance = Matrix6d::Identity() * 1e-4;
  }

  start = std::chrono::steady_clock::now();
  const ScanPoints dense_in_map = transformed(dense, out.T_map_base);
  const Eigen::Vector3d viewpoint = (out.T_map_base * cloud.sensor_pose).translation();
  if (config_.carve_free_space) out.carved_voxels = model_.carve(dense_in_map.points, viewpoint, config_.carve_min_rays);
  model_.insert(dense_in_map, viewpoint);
  out.model_update_ms = ms_since(start);

  const Eigen::Vector3d scanner = (out.T_map_base * cloud.sensor_pose).translation();
  const Eigen::Vector2d position = out.T_map_base.translation().head<2>();
  if (config_.exploration) {
    start = std::chrono::steady_clock::now();
    const double cube = 0.5 * std::min(config_.layered_map.cell_size, config_.layered_map.layer_height);
    const ScanPoints rays = voxel_downsample(cloud.points, {}, cube, out.T_map_base * cloud.sensor_pose);
    layered_map_.integrate(rays.points, scanner);
    out.exploration = planner_.decide(layered_map_, position, scan_positions_);
    out.planning_ms = ms_since(start);
  }
  scan_positions_.push_back(position);
  T_map_base_last_ = out.T_map_base;
  odom_at_last_ = odom_latest_;
  ++scans_;
  return out;
}

}  // namespace locd::icp_explorer
