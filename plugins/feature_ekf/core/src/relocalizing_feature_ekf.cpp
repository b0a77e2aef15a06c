#include "locd/feature_ekf/relocalizing_feature_ekf.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <utility>

namespace locd::feature_ekf {

namespace {

// A uniform distribution over the walls' bounding box and every heading.
Eigen::Matrix3d map_wide_covariance(const FeatureMap2D& map) {
  Eigen::AlignedBox2d box;
  for (const LineFeature& l : map.lines) {
    box.extend(l.a);
    box.extend(l.b);
  }
  const Eigen::Vector2d size = box.isEmpty() ? Eigen::Vector2d(1.0, 1.0) : Eigen::Vector2d(box.sizes().cwiseMax(1.0));
  return Eigen::Vector3d(size.x() * size.x() / 12.0, size.y() * size.y() / 12.0, M_PI * M_PI / 3.0).asDiagonal();
}

size_t features_in_use(const ScanUpdateReport& report, const FeatureEkfConfig& config, bool associated_only) {
  const bool use[3] = {config.use_lines, config.use_corners, config.use_edges};
  size_t n = 0;
  for (const Association& a : report.associations) {
    if (use[static_cast<int>(a.measured_kind)] && (!associated_only || a.associated())) ++n;
  }
  return n;
}

}  // namespace

RelocalizingFeatureEkf::RelocalizingFeatureEkf(FeatureEkfConfig config, FeatureMap2D map)
    : filter_(config, std::move(map)),
      agreement_(filter_.config().agreement, filter_.map()),
      search_(filter_.config().global_search, filter_, agreement_),
      monitor_(filter_.config().monitor),
      lost_covariance_(map_wide_covariance(filter_.map())) {}

bool RelocalizingFeatureEkf::apply_odometry(const Pose2& odometry_pose, int64_t stamp_ns) {
  const bool predicted = filter_.apply_odometry(odometry_pose, stamp_ns);
  if (predicted && state_ == LocalizationState::kLost) search_.predict(*filter_.last_control());
  return predicted;
}

void RelocalizingFeatureEkf::set_pose(const Eigen::Vector3d& pose, const Eigen::Matrix3d& covariance) {
  filter_.set_pose(pose, covariance);
  monitor_.reset();
  search_.reset();
  state_ = LocalizationState::kUnknown;
  confirming_scans_ = 0;
}

Eigen::Matrix3d RelocalizingFeatureEkf::published_covariance() const {
  return state_ == LocalizationState::kLost ? lost_covariance_ : filter_.covariance();
}

ScanOutcome RelocalizingFeatureEkf::update(const LaserScan& scan) {
  ScanOutcome out;
  out.report = filter_.update(scan);
  const FeatureEkfConfig& config = filter_.config();
  ScanStatistics& s = out.statistics;
  s.extracted = features_in_use(out.report, config, false);
  s.associated = features_in_use(out.report, config, true);
  s.nis = out.report.nis;
  s.agreement = agreement_.agreement(scan, Pose2::from_vector(filter_.pose()));
  s.position_stddev =
      std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(filter_.covariance().topLeftCorner<2, 2>())
                                  .eigenvalues()
                                  .maxCoeff()));
  out.localization = monitor_.add(s);
  out.window = monitor_.statistics();
  if (state_ == LocalizationState::kLost && out.localization.state != LocalizationState::kLost &&
      config.global_search.enabled) {
    // Lost is left only through the global search: a filter that lost its way may well lock on
    // to a stretch that looks alike (a corridor turned by 90 degrees) and agree with the scan there.
    out.localization = {LocalizationState::kLost, "lost until the global search finds an unambiguous pose; " + lost_reason_};
  }
  if (out.localization.state == LocalizationState::kLost && state_ != LocalizationState::kLost) {
    lost_reason_ = out.localization.reason;
  }
  if (confirming_scans_ > 0) {
    --confirming_scans_;
    if (out.localization.state == LocalizationState::kTracking) {
      out.localization = {LocalizationState::kUncertain,
                          "relocalized; confirming (" + std::to_string(config.monitor.window_scans - confirming_scans_) +
                              " of " + std::to_string(config.monitor.window_scans) + " scans): " +
                              out.localization.reason};
    }
  }
  if (out.localization.state == LocalizationState::kLost && config.global_search.enabled) {
    if (state_ != LocalizationState::kLost) {
      search_.reset();
      last_generation_ns_.reset();
    }
    const bool generate = !last_generation_ns_ || static_cast<double>(scan.header.stamp_ns - *last_generation_ns_) *
                                                          1e-9 >= config.global_search.interval_s;
    if (generate) last_generation_ns_ = scan.header.stamp_ns;
    out.search = search_.update(out.report.features, scan, generate);
    if (out.search->accepted) {
      filter_.set_pose(out.search->accepted->filter.state(), out.search->accepted->filter.covariance());
      monitor_.reset();
      confirming_scans_ = config.monitor.window_scans;
      out.relocalized = true;
      out.localization = {LocalizationState::kUncertain, out.search->reason};
    }
  }
  state_ = out.localization.state;
  return out;
}

}  // namespace locd::feature_ekf
