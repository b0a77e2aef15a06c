#include "params.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "locd/feature_ekf/landmark_association.hpp"

namespace locd::feature_ekf {
namespace {

Eigen::Vector3d vector3(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

// |latitude| and |longitude| of an operating area's centre, degrees.
constexpr double kMaxCentreLatitude = 85.0;
constexpr double kMaxLongitude = 180.0;

// localization: the state criteria (both models; the landmark models have no scan agreement).
void read_monitor_config(const Params& monitor, MonitorConfig& m) {
  const Range share = Range::closed(0.0, 1.0);
  monitor.expect_only({"window_scans", "lost_window_scans", "lost_agreement", "min_agreement", "lost_association_share",
                       "min_association_share", "min_window_features", "nis_probability", "max_tracking_stddev",
                       "lost_after_uncertain_scans"});
  m.window_scans = static_cast<int>(monitor.integer("window_scans", m.window_scans, 1, 10000));
  m.lost_window_scans = static_cast<int>(monitor.integer("lost_window_scans", m.lost_window_scans, 1, m.window_scans));
  m.lost_agreement = monitor.number("lost_agreement", m.lost_agreement, share);
  m.min_agreement = monitor.number("min_agreement", m.min_agreement, share);
  m.lost_association_share = monitor.number("lost_association_share", m.lost_association_share, share);
  m.min_association_share = monitor.number("min_association_share", m.min_association_share, share);
  m.min_window_features = static_cast<int>(monitor.integer("min_window_features", m.min_window_features, 1, 1000000));
  m.nis_probability = monitor.number("nis_probability", m.nis_probability, Range::open(0.0, 1.0));
  m.max_tracking_stddev = monitor.number("max_tracking_stddev", m.max_tracking_stddev, Range::positive());
  m.lost_after_uncertain_scans =
      static_cast<int>(monitor.integer("lost_after_uncertain_scans", m.lost_after_uncertain_scans, 0, 1000000));
}

// scan_agreement, localization (the state criteria) and global_search (relocalization).
void read_state_config(const Params& params, FeatureEkfConfig& c) {
  const Range positive = Range::positive(), non_negative = Range::non_negative(), share = Range::closed(0.0, 1.0);
  const Params agreement = params.child("scan_agreement");
  agreement.expect_only({"beams", "min_beams", "tolerance", "tolerance_per_metre"});
  ScanAgreementConfig& a = c.agreement;
  a.beams = static_cast<int>(agreement.integer("beams", a.beams, 1, 100000));
  a.min_beams = static_cast<int>(agreement.integer("min_beams", a.min_beams, 1, 100000));
  a.tolerance = agreement.number("tolerance", a.tolerance, positive);
  a.tolerance_per_metre = agreement.number("tolerance_per_metre", a.tolerance_per_metre, non_negative);

  read_monitor_config(params.child("localization"), c.monitor);

  const Params search = params.child("global_search");
  search.expect_only({"enabled", "min_pair_angle", "angle_tolerance", "max_pair_distance", "max_map_pairs", "interval_s",
                      "new_hypotheses", "max_tracked_hypotheses", "merge_distance", "merge_angle",
                      "agreement_smoothing", "drop_agreement", "drop_disagreement", "birth_disagreement",
                      "min_hypothesis_scans", "accept_agreement", "ambiguity_disagreement", "distinct_distance",
                      "distinct_angle", "relocalized_stddev"});
  GlobalSearchConfig& g = c.global_search;
  g.enabled = search.flag("enabled", g.enabled);
  g.min_pair_angle = search.number("min_pair_angle", g.min_pair_angle, Range::open(0.0, M_PI / 2));
  g.angle_tolerance = search.number("angle_tolerance", g.angle_tolerance, Range::open(0.0, M_PI / 2));
  g.max_pair_distance = search.number("max_pair_distance", g.max_pair_distance, positive);
  g.max_map_pairs = static_cast<size_t>(search.integer("max_map_pairs", static_cast<long>(g.max_map_pairs), 1, 100'000'000));
  g.interval_s = search.number("interval_s", g.interval_s, non_negative);
  g.new_hypotheses = static_cast<size_t>(search.integer("new_hypotheses", static_cast<long>(g.new_hypotheses), 1, 10000));
  g.max_tracked_hypotheses = static_cast<size_t>(
      search.integer("max_tracked_hypotheses", static_cast<long>(g.max_tracked_hypotheses), 1, 10000));
  g.merge_distance = search.number("merge_distance", g.merge_distance, positive);
  g.merge_angle = search.number("merge_angle", g.merge_angle, positive);
  g.agreement_smoothing = search.number("agreement_smoothing", g.agreement_smoothing, Range{0.0, 1.0, true, false});
  g.drop_agreement = search.number("drop_agreement", g.drop_agreement, share);
  g.drop_disagreement = search.number("drop_disagreement", g.drop_disagreement, positive);
  g.birth_disagreement = search.number("birth_disagreement", g.birth_disagreement, non_negative);
  g.min_hypothesis_scans = static_cast<int>(search.integer("min_hypothesis_scans", g.min_hypothesis_scans, 1, 100000));
  g.accept_agreement = search.number("accept_agreement", g.accept_agreement, share);
  g.ambiguity_disagreement = search.number("ambiguity_disagreement", g.ambiguity_disagreement, non_negative);
  g.distinct_distance = search.number("distinct_distance", g.distinct_distance, positive);
  g.distinct_angle = search.number("distinct_angle", g.distinct_angle, positive);
  g.relocalized_stddev = vector3(search.numbers(
      "relocalized_stddev", {g.relocalized_stddev.x(), g.relocalized_stddev.y(), g.relocalized_stddev.z()}, 3, positive));
}

FeatureEkfConfig laser_config(const Params& params) {
  params.expect_only({"model", "map", "initial_pose", "initial_stddev", "gate_probability", "max_feature_range",
                      "line_overlap_margin", "use_lines", "use_corners", "use_edges", "max_odometry_gap",
                      "position_stddev_floor", "heading_stddev_floor", "motion", "extraction", "scan_agreement",
                      "localization", "global_search"});
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
  c.position_stddev_floor = params.number("position_stddev_floor", c.position_stddev_floor, non_negative);
  c.heading_stddev_floor = params.number("heading_stddev_floor", c.heading_stddev_floor, non_negative);

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
  read_state_config(params, c);
  return c;
}

LandmarkEkfConfig landmark_config(const Params& params, LandmarkModelKind model) {
  params.expect_only({"model", "landmarks", "association", "gate_threshold", "false_detection_probability",
                      "jcbb_max_nodes", "centre", "altitude", "velocity_noise_per_step", "position_noise_per_step",
                      "detection_stddev", "initial_position", "initial_velocity", "initial_stddev", "max_imu_gap",
                      "frame_id", "localization"});
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
    if (std::fabs(centre[0]) > kMaxCentreLatitude || std::fabs(centre[1]) > kMaxLongitude) {
      params.fail("centre", "[" + std::to_string(centre[0]) + ", " + std::to_string(centre[1]) +
                                "] is out of range; allowed: latitude [-85, 85], longitude [-180, 180] degrees");
    }
    c.centre_deg = Eigen::Vector2d(centre[0], centre[1]);
  }
  c.altitude = params.number("altitude", c.altitude, Range::closed(-1000.0, 10000.0));
  c.velocity_noise_per_step = params.number("velocity_noise_per_step", c.velocity_noise_per_step, non_negative);
  c.position_noise_per_step = params.number("position_noise_per_step", c.position_noise_per_step, non_negative);
  c.detection_stddev = params.number("detection_stddev", c.detection_stddev, non_negative);
  const std::vector<double> p0 = params.numbers("initial_position", {c.initial_position.x(), c.initial_position.y()}, 2);
  const std::vector<double> v0 = params.numbers("initial_velocity", {c.initial_velocity.x(), c.initial_velocity.y()}, 2);
  const std::vector<double> s0 =
      params.numbers("initial_stddev", {c.initial_position_stddev, c.initial_velocity_stddev}, 2, positive);
  c.initial_position = {p0[0], p0[1]};
  c.initial_velocity = {v0[0], v0[1]};
  c.initial_position_stddev = s0[0];
  c.initial_velocity_stddev = s0[1];
  c.max_imu_gap = params.number("max_imu_gap", c.max_imu_gap, positive);
  read_monitor_config(params.child("localization"), c.monitor);
  return c;
}

}  // namespace

const char* model_name(Model model) {
  switch (model) {
    case Model::kLaserFeatures: return "laser_features";
    case Model::kGeodeticLandmarks: return "geodetic_landmarks";
    case Model::kEnuLandmarks: return "enu_landmarks";
  }
  return "?";
}

Config parse_config(const Params& params) {
  Config config;
  const std::string model =
      params.text("model", model_name(config.model),
                  {model_name(Model::kLaserFeatures), model_name(Model::kGeodeticLandmarks), model_name(Model::kEnuLandmarks)});
  if (model == model_name(Model::kLaserFeatures)) {
    config.map = params.required_text("map");
    config.laser = laser_config(params);
    return config;
  }
  config.model = model == model_name(Model::kGeodeticLandmarks) ? Model::kGeodeticLandmarks : Model::kEnuLandmarks;
  const LandmarkModelKind kind =
      config.model == Model::kGeodeticLandmarks ? LandmarkModelKind::kGeodetic : LandmarkModelKind::kEnu;
  config.landmark = landmark_config(params, kind);
  config.landmarks = params.required_text("landmarks");
  config.frame_id = params.text("frame_id", config.frame_id);
  return config;
}

}  // namespace locd::feature_ekf
