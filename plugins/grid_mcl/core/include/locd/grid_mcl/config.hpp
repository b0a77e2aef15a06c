// Every setting of grid_mcl with its default: the one place the defaults live. The plugin
// (plugin/params.cpp) reads a robot's parameters into Config; tests and benchmarks build one
// directly. Names and defaults follow Nav2 AMCL where AMCL has the setting (README: the mapping),
// so an AMCL YAML translates one to one.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "locd/sdk/geometry.hpp"

namespace locd::grid_mcl {

enum class LaserModelType { kLikelihoodField, kLikelihoodFieldProb, kBeam };
enum class MotionModelType { kDifferential, kOmnidirectional };

// AMCL's alpha1..alpha5 (Probabilistic Robotics Table 5.6 for the differential drive; alpha5 is
// the omnidirectional model's strafe noise).
struct MotionNoise {
  double alpha1 = 0.2;  // rotation noise from rotation
  double alpha2 = 0.2;  // rotation noise from translation
  double alpha3 = 0.2;  // translation noise from translation
  double alpha4 = 0.2;  // translation noise from rotation
  double alpha5 = 0.2;  // strafe noise from translation (omnidirectional only)
};

struct LaserModelConfig {
  LaserModelType type = LaserModelType::kLikelihoodField;  // laser_model_type
  int max_beams = 60;                 // beams used per scan, evenly spread over the scan
  double min_range = -1.0;            // laser_min_range, m; < 0: the scan's range_min
  double max_range = 100.0;           // laser_max_range, m; < 0: the scan's range_max
  double z_hit = 0.5;
  double z_short = 0.05;              // beam model only
  double z_max = 0.05;                // beam model only
  double z_rand = 0.5;
  double sigma_hit = 0.2;             // m
  double lambda_short = 0.1;          // 1/m, beam model only
  double likelihood_max_dist = 2.0;   // laser_likelihood_max_dist, m: the field saturates here
                                      // (and at 255 cells in any case: DistanceField)
  // locd: a beam ending in a cell the map does not know (map_server's unknown, or beyond the map)
  // is scored as a wall there with this probability, else as the known field says:
  // pz = u pz(0) + (1 - u) pz(d). 0: as AMCL, the distance to the nearest obstacle only.
  double unknown_occupancy = 0.0;
  // While the filter is lost its field is this wide, while uncertain with the set still spread
  // sqrt(sigma_hit x this), so particles far from any sampled pose still pull the set towards the
  // truth (annealing); 0 (or sigma_hit): always sigma_hit, as AMCL.
  double search_sigma_hit = 0.0;      // m
};

struct FilterConfig {
  size_t min_particles = 500;
  size_t max_particles = 2000;
  size_t global_particles = 50000;    // drawn uniformly over the free cells at a global (re)start
  double pf_err = 0.05;               // KLD epsilon
  double pf_z = 0.99;                 // KLD quantile (1 - delta)
  Eigen::Vector3d kld_bin{0.5, 0.5, 10.0 * M_PI / 180.0};  // AMCL's kd-tree cell: m, m, rad
  int resample_interval = 1;          // resample every n-th filter update
  bool selective_resampling = false;  // ...and only when the effective sample size is below half the set
  // Augmented MCL (AMCL's recovery_alpha_*); both 0 (AMCL's default) disables recovery.
  double recovery_alpha_slow = 0.0;
  double recovery_alpha_fast = 0.0;
  // Kidnapped robot: while the filter holds one pose (localization_state.tracking_min_cluster_mass)
  // a scan fit below localization_state.tracking_min_fit this many updates in a row restarts
  // global localization; 0: never, as AMCL.
  int relocalize_after_lost_updates = 10;
  // Kidnapped along look-alike corridors: the scan still fits the old pose, only returns through
  // the map's walls give it away, and those never restart global localization (real maps lack
  // open doors and glass). After this many uncertain updates (a leaky count: a tracking update
  // takes one off) with the estimate failing the fit or see-through test, the filter scores
  // hypothesis_candidates poses drawn over the free cells and refines the best 8; those at least
  // cluster_radius away that pass both tests and fit no worse than the estimate are followed
  // (carried by the odometry, checked on every scan, dropped when they fail). When one alone is
  // left after hypothesis_confirm_updates updates the filter moves there (state lost until it
  // tracks again); look-alike places wait until the scans tell them apart. 0: never.
  int hypothesis_test_after_uncertain_updates = 10;
  size_t hypothesis_candidates = 4000;
  int hypothesis_confirm_updates = 10;
  double update_min_d = 0.25;         // m of travel before the next filter update
  double update_min_a = 0.2;          // rad of rotation before the next filter update
  double cluster_radius = 1.0;        // m, the estimate: weighted mean within this of the mode
  int threads = 1;                    // weighting threads (1: the calling thread only)
  uint64_t seed = 1;
};

// When the plugin says tracking, uncertain or lost (README: "Localization state").
struct StateCriteria {
  double fit_distance = 0.2;          // m: a beam "fits" when its end lies this close to an obstacle
  double tracking_min_fit = 0.5;      // share of fitting beams for tracking (of those the map knows)
  // Share of the scan's hits the map can judge (ending in a known cell, near an obstacle, or
  // beyond one of its walls) for tracking: where the map lacks most of what the scan sees the
  // pose rests on odometry (bench/realdata, intel: the unmapped corridor).
  double tracking_min_known = 0.5;
  double lost_max_fit = 0.25;         // below: lost
  double tracking_min_cluster_mass = 0.5;  // weight of the main cluster for tracking
  double lost_max_cluster_mass = 0.1;      // below: lost
  double tracking_max_position_stddev = 0.3;  // m, of the main cluster
  double tracking_max_yaw_stddev = 0.15;      // rad
  double tracking_min_fast_slow_ratio = 0.5;  // w_fast / w_slow below: the filter injects, uncertain
  // The likelihood field looks only at where a beam ends, so a pose in the wrong one of two alike
  // corridors fits nearly every beam. What gives it away are the returns that, cast from the
  // estimate over see_through_beams beams of the scan, meet a wall of the map more than
  // see_through_margin + see_through_fraction of their range before they end: above
  // tracking_max_see_through of the returns, uncertain (never a relocalization by itself: see
  // FilterConfig::hypothesis_test_after_uncertain_updates); 1: off.
  double see_through_margin = 0.5;        // m
  double see_through_fraction = 0.1;      // of the return's range (a heading error grows with it)
  int see_through_beams = 180;            // beams checked, evenly spread over the scan
  double tracking_max_see_through = 0.03;  // share of the returns
};

struct Config {
  std::string map;                    // map_server YAML, resolved in the server's map directories
  MotionModelType motion_model = MotionModelType::kDifferential;  // robot_model_type
  MotionNoise motion;
  LaserModelConfig laser;
  FilterConfig filter;
  StateCriteria state;
  std::optional<Pose2> initial_pose;  // set_initial_pose + initial_pose; none: global localization
  Eigen::Vector3d initial_stddev{0.5, 0.5, M_PI / 12.0};  // sqrt of AMCL's initial_cov_xx, _yy, _aa
  // An initial pose whose position stddev reaches this asks for global localization (m).
  double global_localization_stddev = 1000.0;
  size_t diagnostics_particles = 500;  // particles sent on the diagnostics topic (0 = none)
  bool publish_map = true;            // the occupancy grid on the grid topic, once
};

}  // namespace locd::grid_mcl
