// Every setting of emoi_markov with its default: the one place the defaults live. The plugin
// (plugin/params.cpp, config/plugins/emoi_markov.yaml) reads a robot's parameters into
// EmoiMarkovConfig; tests, benchmarks and the simulator build one directly.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace locd::emoi {

// The sensor model of eq. 8 and what the masked model adds (masked_emoi.hpp, markov_grid.hpp).
struct SensorModelConfig {
  double sigma_m = 0.05;            // eq. 8 sigma on the normalised EMOI
  double min_likelihood = 1e-6;     // floor of p(z | x): one bad match never zeroes a cell
  double min_coverage = 0.3;        // a radius with a thinner local map is left out
  double full_coverage = 0.9;       // from here on a radius gets its full weight
  double ground_offset_stddev_m = 0.0;  // masked model: prior on the robot's ground height error
  double shape_sigma_m = 0.035;  // masked model, sparse updates: RMS elevation residual of the local map
                               // against the DSM worth one standard deviation (0 = EMOI only)
  double shape_edge_step_m = 0.5;  // the shape residual leaves out DSM cells stepping by more than
                                   // this to a neighbour (object edges; 0 = none left out)
};

// The odometry's distortion since the last update, marginalised over a grid of hypotheses
// (odometry_distortion.hpp).
struct DistortionConfig {
  double scale_stddev = 0.1;            // odometry scale error (the motion model's odometry_error)
  double direction_stddev_rad = 0.1;    // odometry direction error
  int nodes = 5;                        // hypotheses per axis; 1 = off
  double support_mass = 0.999;          // the hypotheses run on the cells holding this much of the prior...
  size_t max_cells = 20000;             // ... when that takes at most this many matching cells
};

// The robot's local elevation map (eq. 1-5, local_elevation_map.hpp).
struct LocalMapConfig {
  double resolution = 0.1;          // m per cell, the DSM's
  double size_m = 80.0;             // side of the square grid
  double memory_distance_m = 1e9;   // travel after which an un-refreshed cell is forgotten
  double refresh_distance_m = 1e9;  // a cell older than this is overwritten, not maxed, by a new return
  double min_point_range_m = 0.5;   // returns closer than this (robot body) are ignored
};

// The localization state's criteria (belief_assessment.hpp).
struct AssessmentConfig {
  double tracking_radius_m = 1.0;   // tracking vouches for the estimate within this distance...
  double tracking_mass = 0.9;       // ... holding at least this much of the belief
  double min_mode_mass = 0.01;      // a separate region holding this much is a second mode
  double mode_region_mass = 0.99;   // the modes are the connected regions of the cells holding this much
  double mode_cell_m = 1.0;         // the grid the modes and the entropy are found on
  double lost_area_m2 = 1000.0;     // a belief spread wider (exp(entropy) * cell area) is lost
  double max_fit_rms_m = 0.2;       // tracking needs the local map to fit the DSM at the estimate this well
};

struct EmoiMarkovConfig {
  std::string map;                                 // DSM name, resolved by PluginContext::maps
  std::vector<double> radii_m{5.0, 10.0, 15.0};
  SensorModelConfig sensor;
  std::string sensor_model = "masked";             // "masked" (observed cells only) or "full_disk" (paper)
  double match_resolution_m = 0.5;                 // matching grid of the masked model
  double odometry_error = 0.1;                     // blur stddev per metre travelled; also the scale error
  DistortionConfig distortion;                     // odometry distortion hypotheses (scale_stddev = odometry_error)
  double min_blur_m = 0.0;                         // added (in quadrature) to every motion blur
  double update_distance_m = 10.0;                 // travel between sensor updates
  std::string heading_source = "odometry";         // "odometry" (+ offset from set_pose) or "imu"
  bool use_initial_pose = false;                   // false: global localization (uniform belief)
  double base_height_m = 0.0;                      // base_link above the ground
  LocalMapConfig local_map;                        // resolution = the DSM's
  bool cache = true;                               // EMOI layers cached on disk
  size_t belief_output_max_cells = 250'000;        // belief diagnostics grid is pooled to this
  AssessmentConfig assessment;                     // localization state (tracking / uncertain / lost)
};

}  // namespace locd::emoi
