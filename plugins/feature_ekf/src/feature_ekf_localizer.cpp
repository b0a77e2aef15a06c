// The feature_ekf plugin: I/O only. Params -> FeatureEkfConfig, sdk measurements in,
// UpdateResult out; the algorithm is FeatureEkfFilter (feature_ekf_core).
#include <cmath>
#include <memory>
#include <string>

#include "locd/feature_ekf/feature_ekf_filter.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::feature_ekf {

namespace {

Eigen::Vector3d vector3(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

FeatureEkfConfig config_from_params(const Params& params) {
  params.expect_only({"map", "initial_pose", "initial_stddev", "gate_probability", "max_feature_range",
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
    const std::string map_name = params.required_text("map");
    FeatureEkfConfig config = config_from_params(params);
    FeatureMap2D map = load_feature_map(context.maps.resolve(map_name).string(), context.limits.max_map_cells);
    limits_ = context.limits;
    filter_ = std::make_unique<FeatureEkfFilter>(std::move(config), std::move(map));
    last_scan_stamp_ns_.reset();
    last_odometry_stamp_ns_.reset();
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
    filter_->set_pose(pose.vector(), P);
  }

  UpdateResult update(const Measurement& measurement) override {
    require_configured();
    if (const auto* odometry = std::get_if<Odometry>(&measurement)) return update_odometry(*odometry);
    if (const auto* scan = std::get_if<LaserScan>(&measurement)) return update_scan(*scan);
    throw InputError(std::string("feature_ekf: measurement kind '") + kind_name(kind_of(measurement)) +
                     "' is not consumed; allowed: odometry, scan");
  }

  UpdateResult initial_outputs() const override {
    UpdateResult result;
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
    if (!filter_) throw InputError("feature_ekf: not configured");
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
  std::unique_ptr<FeatureEkfFilter> filter_;
  // Stamps must not go backwards within a stream. Across streams they may interleave: a scan
  // stamped before the latest odometry is fused at the current pose.
  std::optional<int64_t> last_scan_stamp_ns_;
  std::optional<int64_t> last_odometry_stamp_ns_;
};

}  // namespace locd::feature_ekf

LOCD_REGISTER_PLUGIN(locd::feature_ekf::FeatureEkfLocalizer, "feature_ekf", "1.0.0",
                     "EKF on 2D laser lines, corners and edges against a feature map (Lim et al.)",
                     locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kLaserScan))
