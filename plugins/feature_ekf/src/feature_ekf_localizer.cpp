// The feature_ekf plugin: I/O only. `model` selects the algorithm (feature_ekf_core):
//   laser_features (default)  FeatureEkfFilter: odometry + 2D scans against a wall feature map;
//   geodetic_landmarks        LandmarkEkfFilter, state [lat, lon, vN, vE]: imu + landmark detections
//   enu_landmarks             LandmarkEkfFilter, state [east, north, vE, vN]     against a database
// Params -> config, sdk measurements in, UpdateResult out.
#include <cmath>
#include <memory>
#include <string>

#include "locd/feature_ekf/feature_ekf_filter.hpp"
#include "locd/feature_ekf/landmark_ekf_filter.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::feature_ekf {

namespace {

Eigen::Vector3d vector3(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

FeatureEkfConfig config_from_params(const Params& params) {
  params.expect_only({"model", "map", "initial_pose", "initial_stddev", "gate_probability", "max_feature_range",
                      "line_overlap_margin", "use_lines", "use_corners", "use_edges", "max_odometry_gap",
                      "motion", "extraction"});
  FeatureEkfConfig c;
  const Range positive = Range::positive(), non_negative = Range::non_negative();
  c.initial_pose = vector3(params.numbers("initial_pose", {c.initial_pose.x(), c.initial_pose.y(), c.initial_pose.z()}, 3));
  c.initial_stddev = vector3(params.numbers(
      "initial_stddev", {c.initial_stddev.x(), c.initial_stddev.y(), c.initial_stddev.z()}, 3, non_negative));
  c.association.gate_probability = params.number("gate_probability", c.association.gate_probability, Range::open(0.0, 1.0));
  c.association.max_range = params.number("max_feature_range", c.association.max_range, positive);
  c.association.line_overlap_margin =
      params.number("line_overlap_margin", c.association.line_overlap_margin, non_negative);
  c.use_lines = params.flag("use_lines", c.use_lines);
  c.use_corners = params.flag("use_corners", c.use_corners);
  c.use_edges = params.flag("use_edges", c.use_edges);
  c.max_odometry_gap = params.number("max_odometry_gap", c.max_odometry_gap, positive);

  const Params motion = params.child("motion");
  motion.expect_only({"speed_stddev_per_speed", "speed_stddev_floor", "turn_stddev_per_turn",
                      "turn_stddev_per_distance", "turn_stddev_floor"});
  MotionNoiseConfig& m = c.motion;
  m.speed_stddev_per_speed = motion.number("speed_stddev_per_speed", m.speed_stddev_per_speed, non_negative);
  m.speed_stddev_floor = motion.number("speed_stddev_floor", m.speed_stddev_floor, non_negative);
  m.turn_stddev_per_turn = motion.number("turn_stddev_per_turn", m.turn_stddev_per_turn, non_negative);
  m.turn_stddev_per_distance = motion.number("turn_stddev_per_distance", m.turn_stddev_per_distance, non_negative);
  m.turn_stddev_floor = motion.number("turn_stddev_floor", m.turn_stddev_floor, non_negative);

  const Params extraction = params.child("extraction");
  extraction.expect_only({"range_stddev", "breakpoint_distance", "breakpoint_min_incidence", "split_distance", "min_points", "min_length",
                          "corner_min_angle", "corner_max_gap", "edge_min_depth_jump", "line_rho_stddev",
                          "line_alpha_stddev", "point_range_stddev", "point_bearing_stddev"});
  ExtractorConfig& e = c.extraction;
  e.range_stddev = extraction.number("range_stddev", e.range_stddev, positive);
  e.breakpoint_distance = extraction.number("breakpoint_distance", e.breakpoint_distance, positive);
  e.breakpoint_min_incidence =
      extraction.number("breakpoint_min_incidence", e.breakpoint_min_incidence, Range::closed(0.0, M_PI / 2));
  e.split_distance = extraction.number("split_distance", e.split_distance, positive);
  e.min_points = static_cast<int>(extraction.integer("min_points", e.min_points, 3, 100000));
  e.min_length = extraction.number("min_length", e.min_length, non_negative);
  e.corner_min_angle = extraction.number("corner_min_angle", e.corner_min_angle, Range::closed(0.0, M_PI / 2));
  e.corner_max_gap = extraction.number("corner_max_gap", e.corner_max_gap, positive);
  e.edge_min_depth_jump = extraction.number("edge_min_depth_jump", e.edge_min_depth_jump, positive);
  e.line_rho_stddev = extraction.number("line_rho_stddev", e.line_rho_stddev, non_negative);
  e.line_alpha_stddev = extraction.number("line_alpha_stddev", e.line_alpha_stddev, non_negative);
  e.point_range_stddev = extraction.number("point_range_stddev", e.point_range_stddev, non_negative);
  e.point_bearing_stddev = extraction.number("point_bearing_stddev", e.point_bearing_stddev, non_negative);
  return c;
}

const char* const kLaserModel = "laser_features";

LandmarkEkfConfig landmark_config_from_params(const Params& params, LandmarkModelKind model) {
  params.expect_only({"model", "landmarks", "association", "gate_threshold", "false_detection_probability",
                      "jcbb_max_nodes", "centre", "altitude", "velocity_noise_per_step", "position_noise_per_step",
                      "detection_stddev", "initial_position", "initial_velocity", "initial_stddev", "max_imu_gap",
                      "frame_id"});
  LandmarkEkfConfig c;
  c.model = model;
  const Range positive = Range::positive(), non_negative = Range::non_negative();
  LandmarkAssociationConfig& a = c.association;
  a.strategy = association_strategy_from_name(
      params.text("association", association_strategy_name(a.strategy), {"known_id", "nearest_neighbor", "jcbb", "pda"}));
  a.gate_threshold = params.number("gate_threshold", a.gate_threshold, Range::open(0.0, 1000.0));
  a.false_detection_probability =
      params.number("false_detection_probability", a.false_detection_probability, Range::open(0.0, 1.0));
  a.jcbb_max_nodes = static_cast<size_t>(params.integer("jcbb_max_nodes", static_cast<long>(a.jcbb_max_nodes), 1, 10'000'000));
  if (params.has("centre")) {
    const std::vector<double> centre = params.numbers("centre", {}, 2);
    if (std::fabs(centre[0]) > 85.0 || std::fabs(centre[1]) > 180.0) {
      params.fail("centre", "[" + std::to_string(centre[0]) + ", " + std::to_string(centre[1]) +
                                "] is out of range; allowed: latitude [-85, 85], longitude [-180, 180] degrees");
    }
    c.centre_deg = Eigen::Vector2d(centre[0], centre[1]);
  }
  c.altitude = params.number("altitude", c.altitude, Range::closed(-1000.0, 10000.0));
  c.velocity_noise_per_step = params.number("velocity_noise_per_step", c.velocity_noise_per_step, non_negative);
  c.position_noise_per_step = params.number("position_noise_per_step", c.position_noise_per_step, non_negative);
  c.detection_stddev = params.number("detection_stddev", c.detection_stddev, non_negative);
  const std::vector<double> p0 = params.numbers("initial_position", {0.0, 0.0}, 2);
  const std::vector<double> v0 = params.numbers("initial_velocity", {0.0, 0.0}, 2);
  const std::vector<double> s0 =
      params.numbers("initial_stddev", {c.initial_position_stddev, c.initial_velocity_stddev}, 2, positive);
  c.initial_position = {p0[0], p0[1]};
  c.initial_velocity = {v0[0], v0[1]};
  c.initial_position_stddev = s0[0];
  c.initial_velocity_stddev = s0[1];
  c.max_imu_gap = params.number("max_imu_gap", c.max_imu_gap, positive);
  return c;
}

bool finite(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

Matrix6d embed_covariance(const Eigen::Matrix3d& P) {
  Matrix6d C = Matrix6d::Zero();
  const int index[3] = {0, 1, 5};  // x, y, yaw in (x, y, z, roll, pitch, yaw)
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) C(index[i], index[j]) = P(i, j);
  return C;
}

}  // namespace

class FeatureEkfLocalizer : public Localizer {
 public:
  void configure(const PluginContext& context, const Params& params) override {
    const std::string model =
        params.text("model", kLaserModel, {kLaserModel, "geodetic_landmarks", "enu_landmarks"});
    filter_.reset();
    landmarks_.reset();
    last_scan_stamp_ns_.reset();
    last_odometry_stamp_ns_.reset();
    last_detections_stamp_ns_.reset();
    limits_ = context.limits;
    if (model != kLaserModel) {
      const LandmarkModelKind kind =
          model == "geodetic_landmarks" ? LandmarkModelKind::kGeodetic : LandmarkModelKind::kEnu;
      LandmarkEkfConfig config = landmark_config_from_params(params, kind);
      const std::string database_name = params.required_text("landmarks");
      frame_id_ = params.text("frame_id", "map");
      LandmarkDatabase database =
          load_landmark_database(context.maps.resolve(database_name).string(), context.limits.max_map_cells);
      landmarks_ = std::make_unique<LandmarkEkfFilter>(std::move(config), std::move(database));
      return;
    }
    const std::string map_name = params.required_text("map");
    FeatureEkfConfig config = config_from_params(params);
    FeatureMap2D map = load_feature_map(context.maps.resolve(map_name).string(), context.limits.max_map_cells);
    filter_ = std::make_unique<FeatureEkfFilter>(std::move(config), std::move(map));
  }

  void set_pose(const PoseEstimate& estimate) override {
    require_configured();
    const Pose2 pose = Pose2::from_isometry(estimate.pose);
    const int index[3] = {0, 1, 5};
    Eigen::Matrix3d P;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) P(i, j) = estimate.covariance(index[i], index[j]);
    if (!pose.vector().allFinite() || !P.allFinite()) {
      throw InputError("feature_ekf: initial pose or covariance is not finite");
    }
    P = 0.5 * (P + P.transpose()).eval();
    if (P.diagonal().minCoeff() < 0.0 || Eigen::LLT<Eigen::Matrix3d>(P + 1e-12 * Eigen::Matrix3d::Identity()).info() != Eigen::Success) {
      throw InputError("feature_ekf: initial covariance (x, y, yaw entries) is not positive semi-definite");
    }
    if (landmarks_) {
      // Position (x = east, y = north) and velocity from the estimate; the velocity keeps the
      // configured uncertainty (a pose carries none for it).
      if (!estimate.linear_velocity.allFinite()) throw InputError("feature_ekf: initial velocity is not finite");
      Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();
      covariance.topLeftCorner<2, 2>() = P.topLeftCorner<2, 2>() + 1e-6 * Eigen::Matrix2d::Identity();
      const double v = landmarks_->config().initial_velocity_stddev;
      covariance.bottomRightCorner<2, 2>() = v * v * Eigen::Matrix2d::Identity();
      landmarks_->set_state_enu(pose.vector().head<2>(), estimate.linear_velocity.head<2>(), covariance);
      return;
    }
    filter_->set_pose(pose.vector(), P);
  }

  UpdateResult update(const Measurement& measurement) override {
    require_configured();
    if (landmarks_) {
      if (const auto* imu = std::get_if<Imu>(&measurement)) return update_imu(*imu);
      if (const auto* detections = std::get_if<LandmarkDetections>(&measurement)) return update_detections(*detections);
      throw InputError(std::string("feature_ekf: measurement kind '") + kind_name(kind_of(measurement)) +
                       "' is not consumed by model " + landmark_model_name(landmarks_->model().kind()) +
                       "; allowed: imu, detections");
    }
    if (const auto* odometry = std::get_if<Odometry>(&measurement)) return update_odometry(*odometry);
    if (const auto* scan = std::get_if<LaserScan>(&measurement)) return update_scan(*scan);
    throw InputError(std::string("feature_ekf: measurement kind '") + kind_name(kind_of(measurement)) +
                     "' is not consumed by model laser_features; allowed: odometry, scan");
  }

  UpdateResult initial_outputs() const override {
    UpdateResult result;
    if (landmarks_) {
      std::vector<MapFeature> features;
      const LandmarkDatabase& db = landmarks_->database();
      for (size_t i = 0; i < db.size(); ++i) {
        const Eigen::Vector3d p(landmarks_->landmark_enu(i).x(), landmarks_->landmark_enu(i).y(), 0.0);
        features.push_back({db[i].id, db[i].class_label, p, p});
      }
      result.landmark_map = std::move(features);
      return result;
    }
    if (!filter_) return result;
    std::vector<MapFeature> features;
    const FeatureMap2D& map = filter_->map();
    for (const LineFeature& l : map.lines) features.push_back({l.id, "line", {l.a.x(), l.a.y(), 0.0}, {l.b.x(), l.b.y(), 0.0}});
    for (const PointFeature& p : map.corners)
      features.push_back({p.id, "corner", {p.position.x(), p.position.y(), 0.0}, {p.position.x(), p.position.y(), 0.0}});
    for (const PointFeature& p : map.edges)
      features.push_back({p.id, "edge", {p.position.x(), p.position.y(), 0.0}, {p.position.x(), p.position.y(), 0.0}});
    result.landmark_map = std::move(features);
    return result;
  }

 private:
  void require_configured() const {
    if (!filter_ && !landmarks_) throw InputError("feature_ekf: not configured");
  }

  // IMU only predicts: it returns no estimate (the pose is published once per detection frame).
  UpdateResult update_imu(const Imu& imu) {
    landmarks_->apply_imu(imu);
    return {};
  }

  UpdateResult update_detections(const LandmarkDetections& detections) {
    if (detections.detections.size() > limits_.max_detections) {
      throw InputError("feature_ekf: " + std::to_string(detections.detections.size()) +
                       " detections; limit max_detections is " + std::to_string(limits_.max_detections));
    }
    if (last_detections_stamp_ns_ && detections.header.stamp_ns < *last_detections_stamp_ns_) {
      throw InputError("feature_ekf: landmark detections stamp " + std::to_string(detections.header.stamp_ns) +
                       " ns goes backwards (previous " + std::to_string(*last_detections_stamp_ns_) + " ns)");
    }
    const LandmarkUpdateReport report = landmarks_->update(detections);
    last_detections_stamp_ns_ = detections.header.stamp_ns;

    UpdateResult result;
    PoseEstimate estimate;
    estimate.header.stamp_ns = detections.header.stamp_ns;
    estimate.header.frame_id = frame_id_;
    const Eigen::Vector2d position = landmarks_->position_enu();
    const Eigen::Vector2d velocity = landmarks_->velocity_enu();
    estimate.pose = Eigen::Isometry3d::Identity();
    estimate.pose.linear() = landmarks_->attitude().toRotationMatrix();
    estimate.pose.translation() = Eigen::Vector3d(position.x(), position.y(), 0.0);
    estimate.linear_velocity = Eigen::Vector3d(velocity.x(), velocity.y(), 0.0);
    estimate.covariance = Matrix6d::Zero();
    estimate.covariance.topLeftCorner<2, 2>() = landmarks_->covariance_enu().topLeftCorner<2, 2>();
    result.estimate = estimate;

    const Eigen::Vector2d geodetic = landmarks_->model().area().to_geodetic(position);
    const Eigen::Matrix4d P = landmarks_->covariance_enu();
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
                {"gate_threshold", landmarks_->association().gate_threshold()}};
    const LandmarkDatabase& db = landmarks_->database();
    for (size_t i = 0; i < report.detections.size(); ++i) {
      const DetectionReport& r = report.detections[i];
      AssociationRecord record;
      record.measurement = static_cast<uint32_t>(i);
      if (r.landmark >= 0) record.feature_id = db[r.landmark].id;
      record.candidates = static_cast<uint32_t>(r.in_gate);
      record.mahalanobis2 = std::isfinite(r.mahalanobis2) ? r.mahalanobis2 : -1.0;
      d.associations.push_back(record);
      d.values.push_back({"detection_" + std::to_string(i) + "_hypotheses", static_cast<double>(r.hypotheses)});
      if (landmarks_->config().association.strategy == AssociationStrategy::kPda) {
        d.values.push_back({"detection_" + std::to_string(i) + "_weight", r.weight});
      }
    }
    return result;
  }

  static void check_stamp(int64_t stamp_ns, const std::optional<int64_t>& last, const char* what) {
    if (last && stamp_ns < *last) {
      throw InputError(std::string("feature_ekf: ") + what + " stamp " + std::to_string(stamp_ns) +
                       " ns goes backwards (previous " + std::to_string(*last) + " ns)");
    }
  }

  // Odometry only predicts: it returns no estimate (the pose is published once per scan).
  UpdateResult update_odometry(const Odometry& odometry) {
    if (!finite(odometry.pose)) throw InputError("feature_ekf: odometry pose has NaN or Inf");
    check_stamp(odometry.header.stamp_ns, last_odometry_stamp_ns_, "odometry");
    if (last_odometry_stamp_ns_ && odometry.header.stamp_ns == *last_odometry_stamp_ns_) {
      throw InputError("feature_ekf: odometry stamp " + std::to_string(odometry.header.stamp_ns) +
                       " ns repeats the previous one");
    }
    last_odometry_stamp_ns_ = odometry.header.stamp_ns;
    filter_->apply_odometry(Pose2::from_isometry(odometry.pose), odometry.header.stamp_ns);
    return {};
  }

  UpdateResult update_scan(const LaserScan& scan) {
    if (scan.ranges.size() > limits_.max_scan_beams) {
      throw InputError("feature_ekf: scan has " + std::to_string(scan.ranges.size()) + " beams; limit max_scan_beams is " +
                       std::to_string(limits_.max_scan_beams));
    }
    if (!std::isfinite(scan.angle_min) || !std::isfinite(scan.angle_increment) || scan.angle_increment == 0.0f ||
        !std::isfinite(scan.range_min) || !std::isfinite(scan.range_max) || scan.range_max <= scan.range_min ||
        !finite(scan.sensor_pose)) {
      throw InputError("feature_ekf: scan geometry is invalid (angle_min, angle_increment != 0, range_min < range_max, "
                       "sensor_pose must be finite)");
    }
    check_stamp(scan.header.stamp_ns, last_scan_stamp_ns_, "scan");
    bool usable = false;
    for (size_t i = 0; i < scan.ranges.size() && !usable; ++i) usable = scan.valid_return(i);
    if (!usable) {
      throw InputError("feature_ekf: scan has no usable return (" + std::to_string(scan.ranges.size()) +
                       " beams, none finite within [range_min, range_max])");
    }
    const ScanUpdateReport report = filter_->update(scan);
    last_scan_stamp_ns_ = scan.header.stamp_ns;

    UpdateResult result;
    PoseEstimate estimate;
    estimate.header.stamp_ns = scan.header.stamp_ns;
    estimate.header.frame_id = filter_->map().frame_id;
    estimate.pose = Pose2::from_vector(filter_->pose()).to_isometry();
    estimate.covariance = embed_covariance(filter_->covariance());
    result.estimate = estimate;

    Diagnostics& d = result.diagnostics;
    const ExtractedFeatures& f = report.features;
    d.values = {{"lines_extracted", static_cast<double>(f.lines.size())},
                {"corners_extracted", static_cast<double>(f.corners.size())},
                {"edges_extracted", static_cast<double>(f.edges.size())},
                {"lines_matched", static_cast<double>(report.matched[0])},
                {"corners_matched", static_cast<double>(report.matched[1])},
                {"edges_matched", static_cast<double>(report.matched[2])},
                {"mean_nis", report.mean_nis}};
    const FeatureMap2D& map = filter_->map();
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

  Limits limits_;
  std::unique_ptr<FeatureEkfFilter> filter_;      // model laser_features
  std::unique_ptr<LandmarkEkfFilter> landmarks_;  // model geodetic_landmarks or enu_landmarks
  std::string frame_id_ = "map";
  std::optional<int64_t> last_detections_stamp_ns_;
  // Stamps must not go backwards within a stream. Across streams they may interleave: a scan
  // stamped before the latest odometry is fused at the current pose.
  std::optional<int64_t> last_scan_stamp_ns_;
  std::optional<int64_t> last_odometry_stamp_ns_;
};

}  // namespace locd::feature_ekf

LOCD_REGISTER_PLUGIN(locd::feature_ekf::FeatureEkfLocalizer, "feature_ekf", "1.1.0",
                     "EKF: 2D laser features against a feature map (Lim et al.), or imu + non-unique "
                     "landmark detections against a landmark database with data association (Kim et al.)",
                     locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kLaserScan,
                                 locd::MeasurementKind::kImu, locd::MeasurementKind::kLandmarkDetections))
