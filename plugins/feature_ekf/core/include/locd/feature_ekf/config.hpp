// Every setting of feature_ekf with its default: the one place the defaults live. The plugin
// (plugin/params.cpp) reads a robot's parameters into Config; tests and benchmarks build one
// directly. Two models share the plugin: laser features (Lim et al.: odometry + 2D scans against
// a wall map) and non-unique landmarks (Kim, Hong, Ra 2018: IMU + detections against a database).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>

namespace locd::feature_ekf {

// ------------------------------------------------------------------ laser features

// Control noise grows with the motion: sigma_v = a |V| + b, sigma_gamma = c |gamma| + d |V dt| + e.
// These are per odometry step, so the variance accumulated over a metre scales with the step
// length: the defaults suit 50 Hz wheel odometry at about 1 m/s drifting ~2-3 % of the distance
// and ~1 deg per metre (per square-root metre, as a random walk).
struct MotionNoiseConfig {
  double speed_stddev_per_speed = 0.2;        // a, (m/s) per (m/s)
  double speed_stddev_floor = 0.01;           // b, m/s
  double turn_stddev_per_turn = 0.15;         // c, rad per rad
  double turn_stddev_per_distance = 0.12;     // d, rad per m
  double turn_stddev_floor = 0.001;           // e, rad
};

struct ExtractorConfig {
  double range_stddev = 0.01;           // m, laser range noise: the point noise of the line fit
  double breakpoint_distance = 0.2;     // m, consecutive points farther apart start a new cluster...
  double breakpoint_min_incidence = 0.1745;  // rad (10 deg), ...unless a surface seen at a larger
                                             // incidence explains the gap (adaptive breakpoint)
  double split_distance = 0.05;         // m, a point farther from its segment's line splits it
  int min_points = 6;                   // points a line needs
  double min_length = 0.3;              // m, length a line needs
  double corner_min_angle = M_PI / 4;   // rad, adjacent lines meeting at a smaller angle are no corner
  double corner_max_gap = 0.3;          // m, line end to intersection for a corner
  double edge_min_depth_jump = 0.3;     // m, the neighbour beam must be this much farther for an edge
  // Added (in quadrature) to every feature's covariance: what the point noise does not explain
  // (map errors, motion during the scan).
  double line_rho_stddev = 0.01;        // m
  double line_alpha_stddev = 0.005;     // rad
  double point_range_stddev = 0.02;     // m
  double point_bearing_stddev = 0.01;   // rad
};

struct AssociationConfig {
  double gate_probability = 0.99;   // chi-square gate probability
  double max_range = 30.0;          // m, map features farther from the predicted pose are not candidates
  double line_overlap_margin = 0.3; // m, slack when a measured segment must overlap a map segment
};

// How well a scan fits the map at a pose (scan_agreement.hpp).
struct ScanAgreementConfig {
  int beams = 90;                     // beams cast per scan (every k-th of the scan)
  int min_beams = 10;                 // fewer informative beams: no verdict
  double tolerance = 0.1;             // m, a beam agrees within tolerance + tolerance_per_metre * range
  double tolerance_per_metre = 0.02;
};

// The localization state from the last window_scans scans (localization_monitor.hpp).
struct MonitorConfig {
  int window_scans = 25;                 // 1 s of a 25 Hz laser: the window of the uncertain criteria
  int lost_window_scans = 5;             // the last 0.2 s: the window of the lost criteria
  double lost_agreement = 0.75;          // mean scan agreement below it: lost
  double min_agreement = 0.95;           // below it: uncertain
  double lost_association_share = 0.2;   // associated / extracted features below it: lost
  double min_association_share = 0.5;    // below it: uncertain
  int min_window_features = 10;          // fewer features in a window: no association verdict
  double nis_probability = 0.999;        // NIS sum above chi2(2 n) at this probability: uncertain
  double max_tracking_stddev = 0.5;      // m, largest position stddev; above it: uncertain
  int lost_after_uncertain_scans = 25;   // uncertain this many scans in a row: lost (0 = never)
};

// Relocalization by a global search of the feature map when lost (global_search.hpp).
struct GlobalSearchConfig {
  bool enabled = true;
  double min_pair_angle = 0.5236;        // rad (30 deg): flatter line pairs give no hypothesis
  double angle_tolerance = 0.0873;       // rad (5 deg): a measured pair's angle against a map pair's
  double max_pair_distance = 60.0;       // m, map line pairs farther apart are never seen together
  size_t max_map_pairs = 200000;         // bound on the precomputed map pairs (configure fails above)
  double interval_s = 0.2;               // s between generations of new hypotheses while lost
  size_t new_hypotheses = 32;            // the best by feature matches join the tracked set
  size_t max_tracked_hypotheses = 64;
  double merge_distance = 0.5;           // m, a new hypothesis this close to a tracked one refreshes it
  double merge_angle = 0.1;              // rad
  double agreement_smoothing = 0.2;      // weight of a new scan in a hypothesis' recent agreement
  double drop_agreement = 0.6;           // a recent agreement below it drops the hypothesis
  double drop_disagreement = 1.0;        // so does summed disagreement this much above the best's
  double birth_disagreement = 0.3;       // a new hypothesis starts this much above the best's sum
  int min_hypothesis_scans = 10;         // scans a hypothesis is scored on before it may be accepted
  double accept_agreement = 0.85;        // the best's recent agreement must reach it, and...
  double ambiguity_disagreement = 0.3;   // ...every distinct rival's sum must exceed the best's by this
  double distinct_distance = 1.0;        // m, rivals closer than this (and distinct_angle) are the same
  double distinct_angle = 0.35;          // rad
  Eigen::Vector3d relocalized_stddev = Eigen::Vector3d(0.1, 0.1, 0.03);  // m, m, rad: the reset covariance
};

struct FeatureEkfConfig {
  MotionNoiseConfig motion;
  ExtractorConfig extraction;
  AssociationConfig association;
  Eigen::Vector3d initial_pose = Eigen::Vector3d::Zero();              // x, y, yaw
  Eigen::Vector3d initial_stddev = Eigen::Vector3d(0.1, 0.1, 0.05);    // m, m, rad
  bool use_lines = true;
  bool use_corners = true;
  bool use_edges = true;
  double max_odometry_gap = 1.0;  // s; a longer gap between odometry messages only restarts it
  // The smallest position stddev (along any direction) and heading stddev the filter holds after a
  // scan. Errors of the map and of the extraction repeat from scan to scan (the same wall, the same
  // fit): sequential updates that treat them as independent would shrink the covariance below the
  // error they leave. 0 = no floor.
  double position_stddev_floor = 0.002;  // m
  double heading_stddev_floor = 0.002;  // rad
  ScanAgreementConfig agreement;
  MonitorConfig monitor;
  GlobalSearchConfig global_search;
};

// ------------------------------------------------------------------ non-unique landmarks

// geodetic: x = [lat, lon, vN, vE]; enu: x = [east, north, vE, vN] (geodetic_models.hpp).
enum class LandmarkModelKind { kGeodetic, kEnu };

// Data association of a detection with the database (landmark_association.hpp).
enum class AssociationStrategy { kKnownId, kNearestNeighbor, kJcbb, kPda };

struct LandmarkAssociationConfig {
  AssociationStrategy strategy = AssociationStrategy::kPda;
  double gate_threshold = 11.9;              // gamma of eq. 24 (chi-square, 2 dof)
  double false_detection_probability = 0.05; // pda: prior that a detection is false
  size_t jcbb_max_nodes = 20000;             // jcbb: interpretation-tree nodes explored per frame
};

struct LandmarkEkfConfig {
  LandmarkModelKind model = LandmarkModelKind::kGeodetic;
  LandmarkAssociationConfig association;
  std::optional<Eigen::Vector2d> centre_deg;  // operating area centre (lat, lon); default: the database's
  double altitude = 0.0;                      // m, h (A3)
  double velocity_noise_per_step = 0.005;     // m/s: Q = diag(0, 0, s^2, s^2) per IMU step (paper)
  double position_noise_per_step = 0.0;       // m
  double detection_stddev = 3.0;              // m, R_p = s^2 I (paper); 0 = each detection's covariance
  Eigen::Vector2d initial_position = Eigen::Vector2d::Zero();  // ENU m about the centre
  Eigen::Vector2d initial_velocity = Eigen::Vector2d::Zero();  // ENU m/s
  double initial_position_stddev = 5.0;       // m
  double initial_velocity_stddev = 0.5;       // m/s
  double max_imu_gap = 0.1;                   // s; a longer gap restarts the prediction
  // The localization state over detection frames: association share and NIS (no scan, so no
  // agreement criterion); positions are metres of a GNSS-free vehicle, hence the wider stddev.
  MonitorConfig monitor = [] {
    MonitorConfig m;
    m.max_tracking_stddev = 10.0;
    m.lost_after_uncertain_scans = 0;  // no search to hand over to
    return m;
  }();
};

// ------------------------------------------------------------------ the plugin's config

enum class Model { kLaserFeatures, kGeodeticLandmarks, kEnuLandmarks };

struct Config {
  Model model = Model::kLaserFeatures;
  // laser_features
  std::string map;                 // wall map, resolved in the server's map directories
  FeatureEkfConfig laser;
  // geodetic_landmarks, enu_landmarks
  std::string landmarks;           // landmark database, resolved in the map directories
  std::string frame_id = "map";    // frame of the published pose
  LandmarkEkfConfig landmark;
};

}  // namespace locd::feature_ekf
