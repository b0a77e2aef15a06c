// Every setting of icp_explorer with its default: the one place the defaults live. The plugin
// (plugin/params.cpp, config/plugins/icp_explorer.yaml) reads a robot's parameters into
// IcpExplorerConfig; tests and benchmarks build one directly.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>

namespace locd::icp_explorer {

// The odometry's error per leg, bounding where a data point can lie (correspondence_rejection.hpp).
struct OdometryErrorBound {
  double forward = 0.5;                // m per leg, along the predicted heading
  double lateral = 0.5;                // m per leg
  double vertical = 0.05;              // m
  double yaw = 10.0 * M_PI / 180.0;    // rad per leg
  double tilt = 1.0 * M_PI / 180.0;    // rad, roll / pitch
  double margin = 0.15;                // m: sensor noise, voxel size, model sampling
};

// The rejection rules (a)-(d) of section 2.1.
struct RejectionRules {
  bool intensity = true;        // (a)
  bool overlap = true;          // (b)
  bool error_length = true;     // (c)
  bool error_direction = true;  // (d)
  double intensity_threshold = 0.25;
  double max_range = 20.0;      // m, the scanner's
};

enum class IcpMetric { kPointToPlane, kPointToPoint };

// Degeneracy (modified_icp.hpp): the information matrix of the normal equations, in a frame at the
// scanner with rotations scaled by the scan's inertia (so every coordinate is metres of point
// motion), is split into eigen-directions. A direction that gets less than min_constraint_share
// of the pairs' total kernel weight from pairs constraining it strongly is poorly constrained:
// the registration does not move the pose along it (the odometry prior holds it) and reports the
// prior's uncertainty there.
// Between min_constraint_share and confident_constraint_share a direction is barely
// constrained: the data move the pose along it, but its reported variance keeps part of the
// prior's (all of it at the lower bound, none at the upper).
struct DegeneracySettings {
  bool hold_to_prior = true;
  double min_constraint_share = 0.003;
  double confident_constraint_share = 0.01;
};

// When a registration is trustworthy (RegistrationResult::converged, the localization state).
struct TrustSettings {
  // Inliers: accepted pairs whose residual (point-to-plane where the model has a normal) is within
  // inlier_distance, among the data points overlapping the model (an accepted pair, its model
  // surface facing the scanner, within overlap_distance; points farther from every model point or
  // facing the back of a thin wall see something new and do not count) whose model point is not
  // on a floor or ceiling (a floor fits whatever the horizontal error).
  double min_inlier_share = 0.5;
  double inlier_distance = 0.15;    // m
  double overlap_distance = 0.5;    // m
  double max_rms_error = 0.08;      // m, RMS residual of the inliers
  int max_degenerate_directions = 2;  // more poorly constrained directions than this: not trustworthy
};

// The coarse stage of the registration (register_coarse_to_fine): the scan and the model at a
// coarse resolution first, with a wide kernel, so that a start far off (1 m, 10 degrees) is pulled
// in by few, far-reaching correspondences before the full-resolution registration.
struct CoarseStageSettings {
  bool enabled = true;
  double voxel_size = 1.0;            // m, scan and model resolution
  double initial_kernel_scale = 2.0;  // m
  double kernel_scale = 0.5;          // m; the fine stage then starts at min(this, initial_kernel_scale)
};

// Gauss-Newton registration (modified_icp.hpp).
struct IcpSettings {
  IcpMetric metric = IcpMetric::kPointToPlane;
  int max_iterations = 40;
  double max_correspondence_distance = 3.0;  // m, always applied (the classic ICP gate)
  double kernel_scale = 0.05;                // m, final Geman-McClure scale
  double initial_kernel_scale = 0.8;         // m, first iterations' scale
  int coarse_stride = 4;                     // while the scale is above 4 x kernel_scale, every n-th data point
  double convergence_translation = 5e-4;     // m, stop when an update moves the scanner less ...
  double convergence_rotation = 1e-4;        // rad, ... and turns less than this
  CoarseStageSettings coarse;
  DegeneracySettings degeneracy;
  TrustSettings trust;
};

// The layered hexahedral map the planner works on (layered_hexahedral_map.hpp).
struct LayeredMapSettings {
  Eigen::Vector2d origin{-10.0, -10.0};  // m, map-frame corner of column (0, 0)
  Eigen::Vector2d size{20.0, 20.0};      // m
  double cell_size = 0.25;               // m
  double layer_height = 0.4;             // m
  double z_min = 0.1;                    // m, above the floor
  double z_max = 2.5;                    // m, below the ceiling
  double occupied_probability = 0.5;
  double points_for_detection = 4.0;
  double fill = 0.25;                    // expected share of a facing cube's returns
  double azimuth_step = 0.5 * M_PI / 180.0;    // rad, the scanner's resolution
  double elevation_step = 0.65 * M_PI / 180.0;
};

// The next-best-view utility (next_best_view.hpp).
struct ExplorationSettings {
  double beta = 1.0;
  double possibly_movable_weight = 0.3;
  double robot_radius = 0.3;         // m
  double robot_height = 1.2;         // m
  double sensor_height = 0.8;        // m, scanner above the floor
  double elevation_min = -45.0 * M_PI / 180.0;
  double elevation_max = 45.0 * M_PI / 180.0;
  double max_range = 20.0;           // m
  int rays = 120;
  int candidate_stride = 2;          // evaluate every n-th column in x and y
  double reliable_distance = 5.0;    // m
  double reliable_falloff = 4.0;     // m
  double overlap_distance = 1.0;     // m
  double direction_penalty = 0.5;
  double memory_radius = 6.0;        // m
  double done_threshold = 0.5;
};

enum class MapFileFormat { kPcd, kPly };

// The registered map on the map_cloud topic and in saved files.
struct MapOutputSettings {
  int publish_every_scans = 1;        // 0 = never publish the map
  double publish_voxel_size = 0.2;    // m
  MapFileFormat save_format = MapFileFormat::kPcd;
};

struct IcpExplorerConfig {
  size_t max_points = 200'000;      // per cloud; larger clouds are refused
  // The intensity that means full reflectivity: intensities are divided by it, so rule (a)'s
  // threshold and the model work on a 0-1 scale. 0 = estimate it from the first cloud with
  // intensity (IcpExplorer::intensity_scale).
  double intensity_scale = 0.0;
  double scan_voxel_size = 0.3;     // m, data points for registration
  double map_voxel_size = 0.1;      // m, the model
  int normal_neighbours = 10;
  bool carve_free_space = true;     // drop once-seen voxels later scans see through (VoxelMap::carve)
  int carve_min_rays = 2;
  IcpSettings icp;
  RejectionRules rejection;
  OdometryErrorBound odometry_bound;
  bool exploration = true;
  LayeredMapSettings layered_map;
  ExplorationSettings planner;
  MapOutputSettings map_output;
};

}  // namespace locd::icp_explorer
