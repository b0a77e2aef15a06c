// A tilting 2D laser scanner (SICK LMS291 style: 181 beams over 180 deg, 80 m) ray cast into a
// DSM surface. The tilt follows a triangle wave; sensor_pose carries the current tilt through
// the mount of paper eq. 1-2, as a real robot would send it.
#pragma once

#include <random>

#include <Eigen/Geometry>

#include "locd/emoi_markov/dsm_io.hpp"
#include "locd/sdk/params.hpp"
#include "locd/sdk/types.hpp"

namespace locd::sim::emoi {

struct TiltingLaserConfig {
  double rate_hz = 10.0;
  int beams = 181;
  double fov_rad = M_PI;
  double range_max_m = 80.0;
  double range_min_m = 0.5;
  double range_stddev_m = 0.02;
  double tilt_min_rad = 0.0;        // positive looks down
  double tilt_max_rad = 0.35;
  double tilt_period_s = 2.0;       // full down-and-up cycle
  double x_tilt = 0.2, z_tilt = 0.5, x_laser = 0.05, z_laser = 0.1;  // mount, eq. 1-2
};

TiltingLaserConfig parse_laser(const Params& laser);

double tilt_at(const TiltingLaserConfig& config, double time_s);

// First intersection of a ray with the heightfield (cell-by-cell traversal, each cell a flat
// column); nullopt when the ray leaves the map or exceeds max_range.
std::optional<double> cast_heightfield(const locd::emoi::ElevationMap& surface, const Eigen::Vector3d& origin,
                                       const Eigen::Vector3d& direction, double max_range);

// The scan seen from base_link pose T_map_base at time_s (stamp in ns).
LaserScan simulate_scan(const TiltingLaserConfig& config, const locd::emoi::ElevationMap& surface,
                        const Eigen::Isometry3d& T_map_base, double time_s, int64_t stamp_ns, std::mt19937_64& rng);

}  // namespace locd::sim::emoi
