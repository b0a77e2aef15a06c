#include "locd/feature_ekf/feature_ekf_filter.hpp"

#include <Eigen/Eigenvalues>

#include "locd/feature_ekf/feature_measurement_model.hpp"

namespace locd::feature_ekf {

FeatureEkfFilter::FeatureEkfFilter(FeatureEkfConfig config, FeatureMap2D map)
    : config_(std::move(config)),
      map_(std::move(map)),
      motion_model_(config_.motion),
      extractor_(config_.extraction),
      association_(config_.association) {
  const Eigen::Vector3d variance = config_.initial_stddev.cwiseProduct(config_.initial_stddev);
  filter_.reset(config_.initial_pose, variance.asDiagonal());
}

void FeatureEkfFilter::set_pose(const Eigen::Vector3d& pose, const Eigen::Matrix3d& covariance) {
  filter_.reset({pose.x(), pose.y(), normalize_angle(pose.z())}, covariance);
}

bool FeatureEkfFilter::apply_odometry(const Pose2& odometry_pose, int64_t stamp_ns) {
  const std::optional<Pose2> previous = last_odometry_pose_;
  const double dt = 1e-9 * static_cast<double>(stamp_ns - last_odometry_stamp_ns_);
  last_odometry_pose_ = odometry_pose;
  last_odometry_stamp_ns_ = stamp_ns;
  last_control_.reset();
  if (!previous || dt <= 0.0 || dt > config_.max_odometry_gap) return false;
  last_control_ = OdometryMotionModel::control_from_odometry(*previous, odometry_pose, dt);
  predict(filter_, *last_control_);
  return true;
}

void FeatureEkfFilter::predict(Filter& filter, const MotionControl& u) const {
  const Eigen::Vector3d x = filter.state();
  filter.predict<2>(OdometryMotionModel::predict(x, u), OdometryMotionModel::jacobian_state(x, u),
                    OdometryMotionModel::jacobian_control(x, u), motion_model_.control_noise(u));
}

void FeatureEkfFilter::apply_covariance_floor(Filter& filter) const {
  Eigen::Matrix3d P = filter.covariance();
  const double floor_xy = config_.position_stddev_floor * config_.position_stddev_floor;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(P.topLeftCorner<2, 2>());
  for (int i = 0; i < 2; ++i) {
    const double missing = floor_xy - eigen.eigenvalues()(i);
    if (missing > 0.0) P.topLeftCorner<2, 2>() += missing * eigen.eigenvectors().col(i) * eigen.eigenvectors().col(i).transpose();
  }
  const double floor_yaw = config_.heading_stddev_floor * config_.heading_stddev_floor;
  if (P(2, 2) < floor_yaw) P(2, 2) = floor_yaw;
  filter.reset(filter.state(), P);
}

ScanUpdateReport FeatureEkfFilter::update(const LaserScan& scan) { return update(extractor_.extract(scan)); }

ScanUpdateReport FeatureEkfFilter::update(ExtractedFeatures features) {
  ScanUpdateReport report = correct(filter_, features);
  report.features = std::move(features);
  return report;
}

ScanUpdateReport FeatureEkfFilter::correct(Filter& filter, const ExtractedFeatures& f) const {
  ScanUpdateReport report;
  // Eq. 8-12 against the predicted pose and covariance.
  report.associations = association_.associate(f, map_, filter.state(), filter.covariance());

  const bool use[3] = {config_.use_lines, config_.use_corners, config_.use_edges};
  double nis_sum = 0.0;
  size_t applied = 0;
  for (const Association& a : report.associations) {
    if (!a.associated() || !use[static_cast<int>(a.measured_kind)]) continue;
    // Eq. 9, 13, 14, sequentially, each relinearized at the current state.
    const Eigen::Vector3d x = filter.state();
    MeasurementJacobian H;
    Measurement2 predicted, measured;
    Eigen::Matrix2d R;
    if (a.measured_kind == FeatureKind::kLine) {
      const ExtractedLine& line = f.lines[a.measurement];
      const LineFeature& map_line = map_.lines[a.map_index];
      predicted = FeatureMeasurementModel::predict_line(map_line.rho(), map_line.alpha(), x, &H);
      measured = line.z;
      R = line.covariance;
    } else {
      const ExtractedPoint& point =
          a.measured_kind == FeatureKind::kCorner ? f.corners[a.measurement] : f.edges[a.measurement];
      const PointFeature& map_point =
          a.map_kind == FeatureKind::kCorner ? map_.corners[a.map_index] : map_.edges[a.map_index];
      predicted = FeatureMeasurementModel::predict_point(map_point.position, x, &H);
      measured = point.z;
      R = point.covariance;
    }
    const Measurement2 innovation = FeatureMeasurementModel::innovation(measured, predicted);
    if (!filter.update<2>(innovation, H, R)) continue;
    Eigen::Vector3d updated = filter.state();
    updated.z() = normalize_angle(updated.z());
    filter.set_state(updated);
    ++report.matched[static_cast<int>(a.measured_kind)];
    nis_sum += a.mahalanobis2;
    report.nis.push_back(a.mahalanobis2);
    ++applied;
  }
  report.mean_nis = applied ? nis_sum / static_cast<double>(applied) : 0.0;
  apply_covariance_floor(filter);
  return report;
}

}  // namespace locd::feature_ekf
