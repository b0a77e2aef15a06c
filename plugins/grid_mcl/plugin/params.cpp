#include "params.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "locd/sdk/ros2_config.hpp"

namespace locd::grid_mcl {
namespace {

// AMCL's beam skipping settings: they act only with do_beamskip, which is refused (AMCL too
// ignores them without it): accepted, ignored.
const char* const kIgnoredAmclKeys[] = {"beam_skip_distance", "beam_skip_threshold", "beam_skip_error_threshold"};

MotionModelType read_motion_model(const Params& p) {
  const std::string name =
      p.text("robot_model_type", "differential",
             {"differential", "omnidirectional", "nav2_amcl::DifferentialMotionModel", "nav2_amcl::OmniMotionModel",
              "diff", "diff-corrected", "omni", "omni-corrected"});
  return name.find("omni") != std::string::npos || name.find("Omni") != std::string::npos
             ? MotionModelType::kOmnidirectional
             : MotionModelType::kDifferential;
}

void read_laser(const Params& p, LaserModelConfig& l) {
  const std::string type = p.text("laser_model_type", "likelihood_field", {"likelihood_field", "likelihood_field_prob", "beam"});
  l.type = type == "beam" ? LaserModelType::kBeam
           : type == "likelihood_field_prob" ? LaserModelType::kLikelihoodFieldProb
                                             : LaserModelType::kLikelihoodField;
  l.max_beams = static_cast<int>(p.integer("max_beams", l.max_beams, 2, 65536));
  l.min_range = p.number("laser_min_range", l.min_range, Range::closed(-1.0, 1000.0));
  l.max_range = p.number("laser_max_range", l.max_range, Range::closed(-1.0, 10000.0));
  if (l.max_range > 0.0 && l.min_range > 0.0 && !(l.max_range > l.min_range)) {
    p.fail("laser_max_range", "= " + std::to_string(l.max_range) + " must exceed laser_min_range = " +
                                  std::to_string(l.min_range));
  }
  l.z_hit = p.number("z_hit", l.z_hit, Range::closed(0.0, 1.0));
  l.z_short = p.number("z_short", l.z_short, Range::closed(0.0, 1.0));
  l.z_max = p.number("z_max", l.z_max, Range::closed(0.0, 1.0));
  l.z_rand = p.number("z_rand", l.z_rand, Range::closed(0.0, 1.0));
  if (!(l.z_hit + l.z_rand > 0.0)) p.fail("z_hit", "and z_rand are both 0; the field needs one of them above 0");
  l.sigma_hit = p.number("sigma_hit", l.sigma_hit, Range{0.0, 100.0, true, false});
  l.lambda_short = p.number("lambda_short", l.lambda_short, Range{0.0, 1000.0, true, false});
  l.likelihood_max_dist = p.number("laser_likelihood_max_dist", l.likelihood_max_dist, Range{0.0, 1000.0, true, false});
  l.unknown_occupancy = p.number("unknown_occupancy", l.unknown_occupancy, Range::closed(0.0, 1.0));
  l.search_sigma_hit = p.number("search_sigma_hit", l.search_sigma_hit, Range::closed(0.0, 100.0));
}

void read_filter(const Params& p, const Limits& limits, FilterConfig& f) {
  const long most = static_cast<long>(std::min<size_t>(limits.max_particles, 10'000'000));
  f.min_particles = static_cast<size_t>(p.integer("min_particles", static_cast<long>(std::min<size_t>(f.min_particles, most)), 1, most));
  f.max_particles = static_cast<size_t>(p.integer("max_particles", std::min<long>(static_cast<long>(f.max_particles), most),
                                                  static_cast<long>(f.min_particles), most));
  f.global_particles =
      static_cast<size_t>(p.integer("global_particles", static_cast<long>(f.max_particles), 1, most));
  f.pf_err = p.number("pf_err", f.pf_err, Range::open(0.0, 1.0));
  f.pf_z = p.number("pf_z", f.pf_z, Range::open(0.5, 1.0));
  const std::vector<double> bin =
      p.numbers("kld_bin", {f.kld_bin.x(), f.kld_bin.y(), f.kld_bin.z()}, 3, Range{0.0, 100.0, true, false});
  f.kld_bin = Eigen::Vector3d(bin[0], bin[1], bin[2]);
  f.resample_interval = static_cast<int>(p.integer("resample_interval", f.resample_interval, 1, 1000));
  f.selective_resampling = p.flag("selective_resampling", f.selective_resampling);
  f.recovery_alpha_slow = p.number("recovery_alpha_slow", f.recovery_alpha_slow, Range{0.0, 1.0, false, true});
  f.recovery_alpha_fast = p.number("recovery_alpha_fast", f.recovery_alpha_fast, Range{0.0, 1.0, false, true});
  const bool recovery = f.recovery_alpha_slow > 0.0 || f.recovery_alpha_fast > 0.0;
  if (recovery && !(f.recovery_alpha_fast > f.recovery_alpha_slow && f.recovery_alpha_slow > 0.0)) {
    p.fail("recovery_alpha_fast", "= " + std::to_string(f.recovery_alpha_fast) + " must exceed recovery_alpha_slow = " +
                                      std::to_string(f.recovery_alpha_slow) + " > 0 (both 0 disable recovery)");
  }
  f.relocalize_after_lost_updates =
      static_cast<int>(p.integer("relocalize_after_lost_updates", f.relocalize_after_lost_updates, 0, 1000000));
  f.hypothesis_test_after_uncertain_updates = static_cast<int>(
      p.integer("hypothesis_test_after_uncertain_updates", f.hypothesis_test_after_uncertain_updates, 0, 1000000));
  f.hypothesis_candidates =
      static_cast<size_t>(p.integer("hypothesis_candidates", static_cast<long>(f.hypothesis_candidates), 1, 1000000));
  f.hypothesis_confirm_updates =
      static_cast<int>(p.integer("hypothesis_confirm_updates", f.hypothesis_confirm_updates, 1, 1000));
  f.update_min_d = p.number("update_min_d", f.update_min_d, Range::closed(0.0, 100.0));
  f.update_min_a = p.number("update_min_a", f.update_min_a, Range::closed(0.0, 2.0 * M_PI));
  f.cluster_radius = p.number("cluster_radius", f.cluster_radius, Range{0.0, 100.0, true, false});
  f.threads = static_cast<int>(p.integer("threads", f.threads, 1, 64));
  f.seed = static_cast<uint64_t>(p.integer("seed", static_cast<long>(f.seed), 0, std::numeric_limits<long>::max()));
}

void read_state(const Params& params, StateCriteria& s) {
  const Params p = params.child("localization_state");
  p.expect_only({"fit_distance", "tracking_min_fit", "tracking_min_known", "lost_max_fit", "tracking_min_cluster_mass", "lost_max_cluster_mass",
                 "tracking_max_position_stddev", "tracking_max_yaw_stddev", "tracking_min_fast_slow_ratio",
                 "tracking_max_see_through", "see_through_margin", "see_through_fraction", "see_through_beams"});
  s.fit_distance = p.number("fit_distance", s.fit_distance, Range{0.0, 100.0, true, false});
  s.tracking_min_fit = p.number("tracking_min_fit", s.tracking_min_fit, Range::closed(0.0, 1.0));
  s.lost_max_fit = p.number("lost_max_fit", s.lost_max_fit, Range::closed(0.0, s.tracking_min_fit));
  s.tracking_min_known = p.number("tracking_min_known", s.tracking_min_known, Range::closed(0.0, 1.0));
  s.tracking_min_cluster_mass = p.number("tracking_min_cluster_mass", s.tracking_min_cluster_mass, Range::closed(0.0, 1.0));
  s.lost_max_cluster_mass =
      p.number("lost_max_cluster_mass", s.lost_max_cluster_mass, Range::closed(0.0, s.tracking_min_cluster_mass));
  s.tracking_max_position_stddev =
      p.number("tracking_max_position_stddev", s.tracking_max_position_stddev, Range{0.0, 1000.0, true, false});
  s.tracking_max_yaw_stddev = p.number("tracking_max_yaw_stddev", s.tracking_max_yaw_stddev, Range{0.0, 10.0, true, false});
  s.tracking_min_fast_slow_ratio =
      p.number("tracking_min_fast_slow_ratio", s.tracking_min_fast_slow_ratio, Range::closed(0.0, 1.0));
  s.tracking_max_see_through = p.number("tracking_max_see_through", s.tracking_max_see_through, Range::closed(0.0, 1.0));
  s.see_through_margin = p.number("see_through_margin", s.see_through_margin, Range::closed(0.0, 100.0));
  s.see_through_fraction = p.number("see_through_fraction", s.see_through_fraction, Range{0.0, 1.0, true, false});
  s.see_through_beams = static_cast<int>(p.integer("see_through_beams", s.see_through_beams, 2, 65536));
}

void read_initial_pose(const Params& p, Config& c) {
  // Nav2: set_initial_pose + initial_pose {x, y, z, yaw}; ROS 1 amcl: initial_cov_xx, _yy, _aa.
  const double xx = p.number("initial_cov_xx", c.initial_stddev.x() * c.initial_stddev.x(), Range{0.0, 1e6, true, false});
  const double yy = p.number("initial_cov_yy", c.initial_stddev.y() * c.initial_stddev.y(), Range{0.0, 1e6, true, false});
  const double aa = p.number("initial_cov_aa", c.initial_stddev.z() * c.initial_stddev.z(), Range{0.0, 100.0, true, false});
  c.initial_stddev = Eigen::Vector3d(std::sqrt(xx), std::sqrt(yy), std::sqrt(aa));
  const Params pose = p.child("initial_pose");
  pose.expect_only({"x", "y", "z", "yaw"});
  const bool set = p.flag("set_initial_pose", false);
  if (set && !p.has("initial_pose")) p.fail("set_initial_pose", "is true but initial_pose {x, y, yaw} is missing");
  if (set) {
    c.initial_pose = Pose2(pose.number("x", 0.0, Range::closed(-1e7, 1e7)), pose.number("y", 0.0, Range::closed(-1e7, 1e7)),
                           normalize_angle(pose.number("yaw", 0.0, Range::closed(-100.0, 100.0))));
    pose.number("z", 0.0, Range::closed(-1e7, 1e7));
  }
  c.global_localization_stddev =
      p.number("global_localization_stddev", c.global_localization_stddev, Range{0.0, 1e9, true, false});
}

}  // namespace

Config parse_config(const Params& params, const Limits& limits, std::vector<std::string>* ignored) {
  // AMCL's ROS keys (frames, topics, tf) are the robot's ros2 section's; a Nav2 params file has
  // them moved there before the plugin sees its parameters (sdk/ros2_config.hpp).
  for (const char* key : kAmclRosKeys) {
    if (params.has(key)) {
      params.fail(key, "is a ROS 2 setting, not grid_mcl's: give the robot's ros2 section its counterpart (README "
                       "\"ROS 2 robots\"), or the whole Nav2 params file (amcl: {ros__parameters: ...}), which "
                       "locd reads as grid_mcl's config with these keys honoured");
    }
  }
  params.expect_only({"map", "robot_model_type", "alpha1", "alpha2", "alpha3", "alpha4", "alpha5", "laser_model_type",
                      "max_beams", "laser_min_range", "laser_max_range", "z_hit", "z_short", "z_max", "z_rand",
                      "sigma_hit", "lambda_short", "laser_likelihood_max_dist", "unknown_occupancy", "search_sigma_hit", "min_particles", "max_particles",
                      "global_particles", "pf_err", "pf_z", "kld_bin", "resample_interval", "selective_resampling", "recovery_alpha_slow",
                      "recovery_alpha_fast", "relocalize_after_lost_updates",
                      "hypothesis_test_after_uncertain_updates", "hypothesis_candidates", "hypothesis_confirm_updates", "update_min_d", "update_min_a", "cluster_radius", "threads", "seed",
                      "set_initial_pose", "initial_pose", "initial_cov_xx", "initial_cov_yy", "initial_cov_aa",
                      "global_localization_stddev", "localization_state", "diagnostics_particles", "publish_map",
                      "do_beamskip", "beam_skip_distance", "beam_skip_threshold", "beam_skip_error_threshold"});
  if (params.flag("do_beamskip", false)) {
    params.fail("do_beamskip", "= true is not supported by grid_mcl; allowed: false");
  }
  if (ignored) {
    for (const char* key : kIgnoredAmclKeys) {
      if (params.has(key)) ignored->push_back(key);
    }
  }
  Config c;
  c.map = params.required_text("map");
  c.motion_model = read_motion_model(params);
  MotionNoise& a = c.motion;
  a.alpha1 = params.number("alpha1", a.alpha1, Range::closed(0.0, 100.0));
  a.alpha2 = params.number("alpha2", a.alpha2, Range::closed(0.0, 100.0));
  a.alpha3 = params.number("alpha3", a.alpha3, Range::closed(0.0, 100.0));
  a.alpha4 = params.number("alpha4", a.alpha4, Range::closed(0.0, 100.0));
  a.alpha5 = params.number("alpha5", a.alpha5, Range::closed(0.0, 100.0));
  read_laser(params, c.laser);
  read_filter(params, limits, c.filter);
  read_state(params, c.state);
  read_initial_pose(params, c);
  c.diagnostics_particles =
      static_cast<size_t>(params.integer("diagnostics_particles", static_cast<long>(c.diagnostics_particles), 0, 65536));
  c.publish_map = params.flag("publish_map", c.publish_map);
  return c;
}

}  // namespace locd::grid_mcl
