// Every setting of ceiling_pf with its default: the one place the defaults live. The plugin
// (plugin/params.cpp) reads a robot's parameters into Config; tests and benchmarks build one
// directly. Defaults follow the paper (Table 3) where it gives them.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "locd/sdk/geometry.hpp"

namespace locd::ceiling_pf {

// N of Table 1 at the most: the size of the candidate buffers of the association. A config asks
// for at most this many (plugin parameter measurement.candidates; NearestLandmarkIndex checks it).
inline constexpr int kMaxCandidates = 32;

struct CameraIntrinsics {
  int width = 640;
  int height = 480;
  double fx = 240.0;  // focal length, pixels
  double fy = 240.0;
  double cx = 319.5;  // principal point, pixels
  double cy = 239.5;
};

// The camera in base_link: position, yaw of the image's top edge, lens height above the floor.
struct CameraMounting {
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;
  double height = 0.32;
};

struct DetectorConfig {
  int blur_kernel = 5;              // odd, pixels
  double blur_sigma = 1.5;          // pixels
  double threshold = 170.0;         // grey level; brighter pixels are landmark candidates
  double hough_dp = 1.0;            // accumulator resolution = image resolution / dp
  double min_distance_px = 20.0;    // between circle centres
  double canny_threshold = 100.0;   // upper Canny threshold inside HoughCircles
  double accumulator_threshold = 10.0;  // at the Hough level
  int min_radius_px = 12;
  int max_radius_px = 22;
  int max_circles = 32;             // more circles in one frame are cut (strongest first)
  int pyramid_levels = 1;           // Hough on the image halved this many times (radii in full-res px)
  bool refine_centroid = true;      // centre = centroid of the full-resolution disk
};

// Table 2's alpha1..alpha6 (paper Table 3).
using MotionNoise = std::array<double, 6>;
inline constexpr MotionNoise kPaperMotionNoise = {0.3, 0.3, 0.1, 0.25, 0.001, 0.001};

struct ParticleFilterConfig {
  // Measurement model (eq. 8-9) and association (Table 1).
  double range_stddev = 0.05;     // m, horizontal range to a landmark
  double bearing_stddev = 0.03;   // rad
  double hit_fraction = 0.95;     // weight of the Gaussian part; the rest is a uniform outlier term
  double max_range = 3.5;         // m, support of the uniform term (camera's view)
  int candidates = 3;             // N of Table 1, 1..kMaxCandidates
  bool scan_all_landmarks = false;  // find the N nearest by scanning the whole map (the direct
                                    // form of Table 1, line 2: the baseline for the grid index)

  // Particle count. Without KLD the count stays at `particles`.
  size_t particles = 500;
  bool kld_sampling = true;
  size_t min_particles = 100;
  size_t max_particles = 20000;
  size_t global_particles = 20000;  // drawn at a global (re)start (the plugin's default: max_particles)
  double kld_epsilon = 0.05;
  double kld_quantile = 0.99;       // 1 - delta
  Eigen::Vector3d kld_bin{0.2, 0.2, 0.1};  // m, m, rad
  double resample_ess_fraction = 0.5;

  // Augmented MCL: short- and long-term averages of the per-detection likelihood.
  bool recovery = true;
  double alpha_slow = 0.001;
  double alpha_fast = 0.1;
  double min_injection_probability = 0.3;  // inject only when 1 - w_fast / w_slow reaches this
  double ambiguous_injection = 0.2;        // share injected after a (re)start until a cluster holds half the weight
  double proposal_position_stddev = 0.05;  // m, noise on poses drawn from detections
  double proposal_heading_stddev = 0.02;   // rad
  double pair_distance_tolerance = 0.15;   // m, detected vs mapped landmark pair distance

  // Estimate: weighted mean of the particles within this radius of the main mode.
  double cluster_radius = 1.0;
  uint64_t seed = 1;
};

// The plugin's config: the map, the camera, the detector and the filter.
struct Config {
  std::string map;                          // landmark map, resolved in the server's map directories
  std::optional<double> ceiling_height;     // m; none: the map's
  CameraIntrinsics camera;
  CameraMounting mounting;
  DetectorConfig detector;
  std::string detection_label;              // detections of this class only ("" = every detection)
  MotionNoise motion_noise = kPaperMotionNoise;
  ParticleFilterConfig filter;
  double index_cell_size = 0.5;             // m, cell of the nearest-landmark index
  double index_margin = 2.0;                // m, the index reaches this far beyond the camera's view
  double view_range_margin = 0.5;           // m, outlier support beyond the camera's widest view
  std::optional<Pose2> initial_pose;        // none: global localization from the first detections
  Eigen::Vector3d initial_stddev{0.3, 0.3, 0.1};  // m, m, rad; also for an initial pose without a usable covariance
  size_t diagnostics_particles = 500;       // particles sent on the diagnostics topic (0 = none)
};

}  // namespace locd::ceiling_pf
