#include "localizer.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <string>

#include "locd/sdk/initial_pose.hpp"
#include "params.hpp"

namespace locd::feature_ekf {
namespace {

// Added to a planar covariance before its Cholesky test, so a semi-definite one passes.
constexpr double kSemiDefiniteSlack = 1e-12;
// Added to the position covariance handed to the landmark filter, so it stays invertible.
constexpr double kPositionVarianceFloor = 1e-6;

// The (x, y, yaw) block of a pose's covariance, symmetrised; InputError unless finite and
// positive semi-definite.
Eigen::Matrix3d checked_planar_covariance(const PoseEstimate& estimate) {
  const PlanarInitialPose start = planar_initial_pose(estimate, "feature_ekf");
  if (!start.covariance_finite) throw InputError("feature_ekf: initial covariance is not finite");
  const Eigen::Matrix3d& P = start.covariance;
  if (P.diagonal().minCoeff() < 0.0 ||
      Eigen::LLT<Eigen::Matrix3d>(P + kSemiDefiniteSlack * Eigen::Matrix3d::Identity()).info() != Eigen::Success) {
    throw InputError("feature_ekf: initial covariance (x, y, yaw entries) is not positive semi-definite");
  }
  return P;
}

[[noreturn]] void not_consumed(const Measurement& measurement, Model model, const char* allowed) {
  throw InputError(std::string("feature_ekf: measurement kind '") + kind_name(kind_of(measurement)) +
                   "' is not consumed by model " + model_name(model) + "; allowed: " + allowed);
}

void require(bool configured) {
  if (!configured) throw InputError("feature_ekf: not configured");
}

MapFeature planar_feature(const std::string& id, const char* kind, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return {id, kind, {a.x(), a.y(), 0.0}, {b.x(), b.y(), 0.0}};
}

}  // namespace

// ------------------------------------------------------------------------- laser features

void LaserFeatureLocalizer::configure(const PluginContext& context, const Params& params) {
  configure(context, parse_config(params));
}

void LaserFeatureLocalizer::configure(const PluginContext& context, const Config& config) {
  FeatureMap2D map = load_feature_map(context.maps.resolve(config.map).string(), context.limits.max_map_cells);
  filter_ = std::make_unique<RelocalizingFeatureEkf>(config.laser, std::move(map));
}

void LaserFeatureLocalizer::set_pose(const PoseEstimate& estimate) {
  require(filter_ != nullptr);
  const Eigen::Matrix3d P = checked_planar_covariance(estimate);
  filter_->set_pose(Pose2::from_isometry(estimate.pose).vector(), P);
}

// Odometry only predicts: it returns no estimate (the pose is published once per scan). Stamps
// may interleave across the two streams: a scan stamped before the latest odometry is fused at
// the current pose.
UpdateResult LaserFeatureLocalizer::update(const Measurement& measurement) {
  require(filter_ != nullptr);
  if (const auto* odometry = std::get_if<Odometry>(&measurement)) {
    filter_->apply_odometry(Pose2::from_isometry(odometry->pose), odometry->header.stamp_ns);
    return {};
  }
  if (const auto* scan = std::get_if<LaserScan>(&measurement)) return on_scan(*scan);
  not_consumed(measurement, Model::kLaserFeatures, "odometry, scan");
}

UpdateResult LaserFeatureLocalizer::on_scan(const LaserScan& scan) {
  const ScanOutcome outcome = filter_->update(scan);
  const ScanUpdateReport& report = outcome.report;
  UpdateResult result;
  PoseEstimate estimate;
  estimate.header.stamp_ns = scan.header.stamp_ns;
  estimate.header.frame_id = filter_->filter().map().frame_id;
  estimate.pose = Pose2::from_vector(filter_->pose()).to_isometry();
  estimate.covariance = pose_covariance(filter_->published_covariance());
  result.estimate = estimate;
  result.localization = outcome.localization;

  Diagnostics& d = result.diagnostics;
  const ExtractedFeatures& f = report.features;
  d.values = {{"lines_extracted", static_cast<double>(f.lines.size())},
              {"corners_extracted", static_cast<double>(f.corners.size())},
              {"edges_extracted", static_cast<double>(f.edges.size())},
              {"lines_matched", static_cast<double>(report.matched[0])},
              {"corners_matched", static_cast<double>(report.matched[1])},
              {"edges_matched", static_cast<double>(report.matched[2])},
              {"mean_nis", report.mean_nis}};
  const WindowStatistics& w = outcome.window;
  if (outcome.statistics.agreement) d.values.push_back({"scan_agreement", *outcome.statistics.agreement});
  if (w.mean_agreement) d.values.push_back({"window_scan_agreement", *w.mean_agreement});
  if (w.association_share) d.values.push_back({"window_association_share", *w.association_share});
  if (w.updates) d.values.push_back({"window_nis_mean", w.nis_sum / static_cast<double>(w.updates)});
  if (outcome.search) {
    d.values.push_back({"relocalization_hypotheses", static_cast<double>(outcome.search->tracked.size())});
    if (!outcome.search->tracked.empty()) {
      d.values.push_back({"relocalization_best_agreement", outcome.search->tracked.front().recent});
    }
    d.values.push_back({"relocalized", outcome.relocalized ? 1.0 : 0.0});
  }
  const FeatureMap2D& map = filter_->filter().map();
  for (size_t i = 0; i < report.associations.size(); ++i) {
    const Association& a = report.associations[i];
    AssociationRecord record;
    record.measurement = static_cast<uint32_t>(i);
    if (a.associated()) {
      record.feature_id = a.map_kind == FeatureKind::kLine     ? map.lines[a.map_index].id
                          : a.map_kind == FeatureKind::kCorner ? map.corners[a.map_index].id
                                                               : map.edges[a.map_index].id;
    }
    record.candidates = a.candidates_in_gate;
    record.mahalanobis2 = std::isfinite(a.mahalanobis2) ? a.mahalanobis2 : -1.0;
    d.associations.push_back(record);
  }
  return result;
}

UpdateResult LaserFeatureLocalizer::initial_outputs() const {
  UpdateResult result;
  if (!filter_) return result;
  std::vector<MapFeature> features;
  const FeatureMap2D& map = filter_->filter().map();
  for (const LineFeature& l : map.lines) features.push_back(planar_feature(l.id, "line", l.a, l.b));
  for (const PointFeature& p : map.corners) features.push_back(planar_feature(p.id, "corner", p.position, p.position));
  for (const PointFeature& p : map.edges) features.push_back(planar_feature(p.id, "edge", p.position, p.position));
  result.landmark_map = std::move(features);
  return result;
}

// ------------------------------------------------------------------------- landmarks

void LandmarkLocalizer::configure(const PluginContext& context, const Params& params) {
  configure(context, parse_config(params));
}

void LandmarkLocalizer::configure(const PluginContext& context, const Config& config) {
  LandmarkDatabase database =
      load_landmark_database(context.maps.resolve(config.landmarks).string(), context.limits.max_map_cells);
  frame_id_ = config.frame_id;
  filter_ = std::make_unique<LandmarkEkfFilter>(config.landmark, std::move(database));
  monitor_ = LocalizationMonitor(config.landmark.monitor);
}

void LandmarkLocalizer::set_pose(const PoseEstimate& estimate) {
  require(filter_ != nullptr);
  const Eigen::Matrix3d P = checked_planar_covariance(estimate);
  // Position (x = east, y = north) and velocity from the estimate; the velocity keeps the
  // configured uncertainty (a pose carries none for it).
  if (!estimate.linear_velocity.allFinite()) throw InputError("feature_ekf: initial velocity is not finite");
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();
  covariance.topLeftCorner<2, 2>() = P.topLeftCorner<2, 2>() + kPositionVarianceFloor * Eigen::Matrix2d::Identity();
  const double v = filter_->config().initial_velocity_stddev;
  covariance.bottomRightCorner<2, 2>() = v * v * Eigen::Matrix2d::Identity();
  filter_->set_state_enu(estimate.pose.translation().head<2>(), estimate.linear_velocity.head<2>(), covariance);
  monitor_.reset();
}

// IMU only predicts: it returns no estimate (the pose is published once per detection frame).
UpdateResult LandmarkLocalizer::update(const Measurement& measurement) {
  require(filter_ != nullptr);
  if (const auto* imu = std::get_if<Imu>(&measurement)) {
    filter_->apply_imu(*imu);
    return {};
  }
  if (const auto* detections = std::get_if<LandmarkDetections>(&measurement)) return on_detections(*detections);
  not_consumed(measurement,
               filter_->model().kind() == LandmarkModelKind::kGeodetic ? Model::kGeodeticLandmarks : Model::kEnuLandmarks,
               "imu, detections");
}

UpdateResult LandmarkLocalizer::on_detections(const LandmarkDetections& detections) {
  const LandmarkUpdateReport report = filter_->update(detections);
  UpdateResult result;
  PoseEstimate estimate;
  estimate.header.stamp_ns = detections.header.stamp_ns;
  estimate.header.frame_id = frame_id_;
  const Eigen::Vector2d position = filter_->position_enu();
  const Eigen::Vector2d velocity = filter_->velocity_enu();
  estimate.pose = Eigen::Isometry3d::Identity();
  estimate.pose.linear() = filter_->attitude().toRotationMatrix();
  estimate.pose.translation() = Eigen::Vector3d(position.x(), position.y(), 0.0);
  estimate.linear_velocity = Eigen::Vector3d(velocity.x(), velocity.y(), 0.0);
  estimate.covariance = Matrix6d::Zero();
  estimate.covariance.topLeftCorner<2, 2>() = filter_->covariance_enu().topLeftCorner<2, 2>();
  result.estimate = estimate;

  const Eigen::Vector2d geodetic = filter_->model().area().to_geodetic(position);
  const Eigen::Matrix4d P = filter_->covariance_enu();
  ScanStatistics frame;
  for (const DetectionReport& r : report.detections) {
    ++frame.extracted;
    if (r.landmark >= 0) ++frame.associated;
    if (r.applied && r.mahalanobis2 >= 0.0) frame.nis.push_back(r.mahalanobis2);
  }
  frame.position_stddev = std::sqrt(
      std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(P.topLeftCorner<2, 2>()).eigenvalues().maxCoeff()));
  result.localization = monitor_.add(frame);
  Diagnostics& d = result.diagnostics;
  size_t hypotheses = 0, in_gate = 0;
  for (const DetectionReport& r : report.detections) {
    hypotheses += r.hypotheses;
    in_gate += r.in_gate;
  }
  d.values = {{"latitude_deg", geodetic.x() * 180.0 / M_PI},
              {"longitude_deg", geodetic.y() * 180.0 / M_PI},
              {"velocity_east", velocity.x()},
              {"velocity_north", velocity.y()},
              {"velocity_stddev", std::sqrt(0.5 * (P(2, 2) + P(3, 3)))},
              {"detections", static_cast<double>(report.detections.size())},
              {"detections_applied", static_cast<double>(report.applied)},
              {"hypotheses", static_cast<double>(hypotheses)},
              {"hypotheses_in_gate", static_cast<double>(in_gate)},
              {"gate_threshold", filter_->association().gate_threshold()}};
  const LandmarkDatabase& db = filter_->database();
  for (size_t i = 0; i < report.detections.size(); ++i) {
    const DetectionReport& r = report.detections[i];
    AssociationRecord record;
    record.measurement = static_cast<uint32_t>(i);
    if (r.landmark >= 0) record.feature_id = db[r.landmark].id;
    record.candidates = static_cast<uint32_t>(r.in_gate);
    record.mahalanobis2 = std::isfinite(r.mahalanobis2) ? r.mahalanobis2 : -1.0;
    d.associations.push_back(record);
    d.values.push_back({"detection_" + std::to_string(i) + "_hypotheses", static_cast<double>(r.hypotheses)});
    if (filter_->config().association.strategy == AssociationStrategy::kPda) {
      d.values.push_back({"detection_" + std::to_string(i) + "_weight", r.weight});
    }
  }
  return result;
}

UpdateResult LandmarkLocalizer::initial_outputs() const {
  UpdateResult result;
  if (!filter_) return result;
  std::vector<MapFeature> features;
  const LandmarkDatabase& db = filter_->database();
  for (size_t i = 0; i < db.size(); ++i) {
    const Eigen::Vector2d p = filter_->landmark_enu(i);
    features.push_back(planar_feature(db[i].id, db[i].class_label.c_str(), p, p));
  }
  result.landmark_map = std::move(features);
  return result;
}

// ------------------------------------------------------------------------- the registered one

void FeatureEkfLocalizer::configure(const PluginContext& context, const Params& params) {
  const Config config = parse_config(params);
  std::unique_ptr<Localizer> next;
  if (config.model == Model::kLaserFeatures) {
    auto laser = std::make_unique<LaserFeatureLocalizer>();
    laser->configure(context, config);
    next = std::move(laser);
  } else {
    auto landmarks = std::make_unique<LandmarkLocalizer>();
    landmarks->configure(context, config);
    next = std::move(landmarks);
  }
  model_ = std::move(next);
}

Localizer& FeatureEkfLocalizer::model() const {
  require(model_ != nullptr);
  return *model_;
}

void FeatureEkfLocalizer::set_pose(const PoseEstimate& pose) { model().set_pose(pose); }
UpdateResult FeatureEkfLocalizer::update(const Measurement& measurement) { return model().update(measurement); }
UpdateResult FeatureEkfLocalizer::initial_outputs() const { return model_ ? model_->initial_outputs() : UpdateResult{}; }

}  // namespace locd::feature_ekf
