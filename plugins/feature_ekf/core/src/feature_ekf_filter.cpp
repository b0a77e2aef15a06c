#include "locd/feature_ekf/feature_ekf_filter.hpp"

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
  if (!previous || dt <= 0.0 || dt > config_.max_odometry_gap) return false;
  const MotionControl u = OdometryMotionModel::control_from_odometry(*previous, odometry_pose, dt);
  const Eigen::Vector3d x = filter_.state();
  filter_.predict<2>(OdometryMotionModel::predict(x, u), OdometryMotionModel::jacobian_state(x, u),
                     OdometryMotionModel::jacobian_control(x, u), motion_model_.control_noise(u));
  return true;
}

ScanUpdateReport FeatureEkfFilter::update(const LaserScan& scan) { return update(extractor_.extract(scan)); }

ScanUpdateReport FeatureEkfFilter::update(ExtractedFeatures features) {
  ScanUpdateReport report;
  report.features = std::move(features);
  const ExtractedFeatures& f = report.features;
  // Eq. 8-12 against the predicted pose and covariance.
  report.associations = association_.associate(f, map_, filter_.state(), filter_.covariance());

  const bool use[3] = {config_.use_lines, config_.use_corners, config_.use_edges};
  double nis_sum = 0.0;
  size_t applied = 0;
  for (const Association& a : report.associations) {
    if (!a.associated() || !use[static_cast<int>(a.measured_kind)]) continue;
    // Eq. 9, 13, 14, sequentially, each relinearized at the current state.
    const Eigen::Vector3d x = filter_.state();
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
    if (!filter_.update<2>(innovation, H, R)) continue;
    Eigen::Vector3d updated = filter_.state();
    updated.z() = normalize_angle(updated.z());
    filter_.set_state(updated);
    ++report.matched[static_cast<int>(a.measured_kind)];
    nis_sum += a.mahalanobis2;
    ++applied;
  }
  report.mean_nis = applied ? nis_sum / static_cast<double>(applied) : 0.0;
  return report;
}

}  // namespace locd::feature_ekf
