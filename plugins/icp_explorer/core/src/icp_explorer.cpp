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

// d(x, y, z, roll, pitch, yaw) = A xi for a left perturbation xi = (v, omega) of T: the
// translation moves by v + omega x t, and omega = E(roll, pitch, yaw) d(roll, pitch, yaw) (ZYX).
Matrix6d pose_from_xi(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d ypr = T.linear().eulerAngles(2, 1, 0);
  const double yaw = ypr[0], pitch = ypr[1];
  Eigen::Matrix3d E;
  E << std::cos(yaw) * std::cos(pitch), -std::sin(yaw), 0, std::sin(yaw) * std::cos(pitch), std::cos(yaw), 0,
      -std::sin(pitch), 0, 1;
  Matrix6d A = Matrix6d::Identity();
  A.topRightCorner<3, 3>() = -skew(T.translation());
  A.bottomRightCorner<3, 3>() = E.inverse();
  return A;
}

// The right-hand-side choice for a uniform error within +-bound.
double uniform_variance(double bound) { return bound * bound / 3.0; }

// The smallest of the usual full scales (1, 255, 65535) at or above `largest`, or `largest` itself.
double full_scale(double largest) {
  for (double scale : {1.0, 255.0, 65535.0})
    if (largest <= scale) return scale;
  return largest;
}
}  // namespace

Matrix6d IcpExplorer::pose_covariance(const Matrix6d& covariance_xi, const Eigen::Isometry3d& T_map_base) {
  const Matrix6d A = pose_from_xi(T_map_base);
  const Matrix6d C = A * covariance_xi * A.transpose();
  return 0.5 * (C + C.transpose());
}

Matrix6d IcpExplorer::xi_covariance(const Matrix6d& pose_covariance, const Eigen::Isometry3d& T_map_base) {
  const Matrix6d A_inverse = pose_from_xi(T_map_base).inverse();
  const Matrix6d C = A_inverse * pose_covariance * A_inverse.transpose();
  return 0.5 * (C + C.transpose());
}

Matrix6d IcpExplorer::prior_covariance_xi() const {
  const OdometryErrorBound& b = config_.odometry_bound;
  Vector6d leg;
  leg << uniform_variance(b.forward), uniform_variance(b.lateral), uniform_variance(b.vertical),
      uniform_variance(b.tilt), uniform_variance(b.tilt), uniform_variance(b.yaw);
  // The leg's error is in the base frame at its end (T_true = T_pred exp(n)): exp(Ad n) T_pred.
  const Matrix6d Ad = se3_adjoint(predicted_pose());
  return covariance_xi_ + Ad * leg.asDiagonal() * Ad.transpose();
}

IcpExplorer::IcpExplorer(const IcpExplorerConfig& config)
    : config_(config),
      model_(config.map_voxel_size, config.normal_neighbours),
      layered_map_(config.layered_map),
      planner_(config.planner),
      coarse_model_(config.icp.coarse.voxel_size, config.normal_neighbours),
      intensity_scale_(config.intensity_scale) {}

void IcpExplorer::set_pose(const Eigen::Isometry3d& T_map_base, const Matrix6d& pose_covariance) {
  T_map_base_last_ = T_map_base;
  odom_at_last_ = odom_latest_;
  // Before the first scan the pose anchors the map; later it is a relocalization within it.
  covariance_xi_ = model_.empty() ? Matrix6d::Zero() : xi_covariance(pose_covariance, T_map_base);
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

  // Intensities on a 0-1 scale (rule (a), the model).
  std::vector<float> intensity = cloud.intensity;
  if (!intensity.empty()) {
    if (intensity_scale_ <= 0.0) {
      float largest = 0.0f;
      for (float i : intensity)
        if (std::isfinite(i)) largest = std::max(largest, i);
      intensity_scale_ = full_scale(largest);
    }
    if (intensity_scale_ != 1.0)
      for (float& i : intensity) i = static_cast<float>(i / intensity_scale_);
  }

  auto start = std::chrono::steady_clock::now();
  const ScanPoints source = voxel_downsample(cloud.points, intensity, config_.scan_voxel_size, cloud.sensor_pose);
  const ScanPoints dense = voxel_downsample(cloud.points, intensity, config_.map_voxel_size, cloud.sensor_pose);
  out.source_points = source.size();
  out.preprocess_ms = ms_since(start);

  out.T_map_base_predicted = predicted_pose();
  out.T_map_base = out.T_map_base_predicted;
  const Matrix6d prior = prior_covariance_xi();
  Matrix6d covariance = Matrix6d::Zero();
  out.added_to_model = true;
  if (!model_.empty()) {
    start = std::chrono::steady_clock::now();
    CorrespondenceRejector rejector(config_.rejection, config_.odometry_bound, out.T_map_base_predicted,
                                    cloud.sensor_pose);
    if (out.intensity_missing) rejector.disable_intensity();
    out.registration =
        register_coarse_to_fine(source, model_, &coarse_model_, out.T_map_base_predicted, rejector, config_.icp);
    out.registration_ms = ms_since(start);
    out.registered = true;
    const RegistrationResult& r = out.registration;
    if (r.fits) {
      out.T_map_base = r.T_map_base;
      // No direction is known better than a tenth of a map voxel of the scan's point motion (the
      // model's resolution; sigma^2 H^+ alone assumes independent residuals, which voxel
      // sampling errors are not).
      const double floor = 0.1 * config_.map_voxel_size;
      covariance = r.covariance + model_covariance(r) + r.prior_projector * prior * r.prior_projector.transpose() +
                   floor * floor * r.local_to_xi * r.local_to_xi.transpose();
      // A scan that fits extends the map even when the iterations ran out: leaving it out thins the
      // map ahead of the robot, and the next registrations get worse (measured in the corridor).
      out.localization.state = r.converged ? LocalizationState::kTracking : LocalizationState::kUncertain;
      out.localization.reason = r.verdict;
    } else {
      // The scan contradicts the model where odometry puts it: keep the prediction, leave the model alone.
      covariance = prior;
      out.added_to_model = false;
      out.localization.state = LocalizationState::kLost;
      out.localization.reason = "scan does not fit the map (" + r.verdict + "); odometry only";
    }
  } else {
    out.localization.state = LocalizationState::kTracking;
    out.localization.reason = "first scan: the map starts at this pose";
  }
  covariance = 0.5 * (covariance + covariance.transpose());
  out.covariance = pose_covariance(covariance, out.T_map_base);
  covariance_xi_ = covariance;
  T_map_base_last_ = out.T_map_base;
  odom_at_last_ = odom_latest_;
  ++scans_;
  const Eigen::Vector2d position = out.T_map_base.translation().head<2>();
  if (!out.added_to_model) {
    if (config_.exploration) out.exploration = planner_.decide(layered_map_, position, scan_positions_);
    return out;
  }

  start = std::chrono::steady_clock::now();
  const ScanPoints dense_in_map = transformed(dense, out.T_map_base);
  const Eigen::Vector3d viewpoint = (out.T_map_base * cloud.sensor_pose).translation();
  if (config_.carve_free_space) out.carved_voxels = model_.carve(dense_in_map.points, viewpoint, config_.carve_min_rays);
  model_.insert(dense_in_map, viewpoint);
  coarse_model_.insert(dense_in_map, viewpoint);
  insert_covariance_.push_back(covariance);
  out.model_update_ms = ms_since(start);

  const Eigen::Vector3d scanner = (out.T_map_base * cloud.sensor_pose).translation();
  if (config_.exploration) {
    start = std::chrono::steady_clock::now();
    const double cube = 0.5 * std::min(config_.layered_map.cell_size, config_.layered_map.layer_height);
    const ScanPoints rays = voxel_downsample(cloud.points, {}, cube, out.T_map_base * cloud.sensor_pose);
    layered_map_.integrate(rays.points, scanner);
    out.exploration = planner_.decide(layered_map_, position, scan_positions_);
    out.planning_ms = ms_since(start);
  }
  scan_positions_.push_back(position);
  return out;
}

Matrix6d IcpExplorer::model_covariance(const RegistrationResult& r) const {
  // A_s = M_s S_s M_s^T, M_s = H^+ H_s: what scan s's own error does to this pose. Their sum's
  // covariance is at most (sum_s c_s) sum_s A_s / c_s for any c_s > 0, whatever the correlation
  // between the scans (Cauchy-Schwarz); c_s = sqrt(tr A_s) makes the bound's trace the smallest.
  std::vector<Matrix6d> A;
  std::vector<double> c;
  double c_sum = 0.0;
  for (const auto& [insert, H] : r.information_by_insert) {
    if (insert >= insert_covariance_.size()) continue;
    const Matrix6d M = r.constrained_inverse * H;
    A.push_back(M * insert_covariance_[insert] * M.transpose());
    c.push_back(std::sqrt(std::max(A.back().trace(), 0.0)));
    c_sum += c.back();
  }
  Matrix6d sum = Matrix6d::Zero();
  for (size_t k = 0; k < A.size(); ++k)
    if (c[k] > 0.0) sum += c_sum / c[k] * A[k];
  return sum;
}

}  // namespace locd::icp_explorer
