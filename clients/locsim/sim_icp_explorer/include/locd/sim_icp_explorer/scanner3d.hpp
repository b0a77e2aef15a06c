// A 3D laser scanner standing still while it scans: azimuth over 360 degrees, elevation over a
// band (about 90 degrees), range noise, intensity = surface reflectivity shaded by the incidence
// angle plus noise. Deterministic from the random engine it is given.
#pragma once

#include <random>
#include <vector>

#include "locd/sdk/params.hpp"
#include "locd/sdk/types.hpp"
#include "locd/sim_icp_explorer/indoor_world.hpp"

namespace locd::sim {

struct Scanner3DConfig {
  int azimuth_steps = 720;            // over 360 degrees
  int elevation_steps = 140;          // over [elevation_min, elevation_max]
  double elevation_min_deg = -45.0;
  double elevation_max_deg = 45.0;
  double max_range = 20.0;            // m
  double range_stddev = 0.005;        // m
  double intensity_stddev = 0.02;
  double incidence_shading = 0.2;     // intensity = reflectivity * (1 - s + s * |cos incidence|)
  double sensor_height = 0.8;         // m, sensor above base_link
  bool with_intensity = true;

  static Scanner3DConfig from_params(const Params& params);
};

// A scan with its truth: which object each point hit (IndoorWorld::cast's RayHit::object).
struct SimulatedScan {
  PointCloud cloud;                  // sensor frame, sensor_pose = sensor in base_link
  std::vector<int> hit_object;       // one per point
  std::vector<Eigen::Vector3f> points_in_world;  // exact (noise-free) hit points, world frame
  Eigen::Vector3f sensor_in_world = Eigen::Vector3f::Zero();  // where the rays start
};

class Scanner3D {
 public:
  explicit Scanner3D(const Scanner3DConfig& config);

  // A scan taken from base_link pose `robot_in_world` at time t (stamped stamp_ns).
  SimulatedScan scan(const IndoorWorld& world, const Eigen::Isometry3d& robot_in_world, double t, int64_t stamp_ns,
                     std::mt19937_64& rng) const;

  Eigen::Isometry3d sensor_in_base() const;
  const Scanner3DConfig& config() const { return config_; }
  // Angular step between neighbouring beams (azimuth, elevation), rad.
  double azimuth_step() const;
  double elevation_step() const;

 private:
  Scanner3DConfig config_;
  std::vector<Eigen::Vector3d> directions_;  // sensor frame, unit
};

}  // namespace locd::sim
