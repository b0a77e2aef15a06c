// Synthetic outdoor worlds for emoi_markov: fractal hills (octaves of smooth value noise),
// buildings (flat-roofed boxes), walls and trees on them. Deterministic from the seed.
// `terrain` is the ground the robot drives on; `surface` (ground + objects) is what a laser
// sees and what a DSM records.
#pragma once

#include <array>
#include <cstdint>

#include "locd/emoi_markov/dsm_io.hpp"
#include "locd/sdk/params.hpp"

namespace locd::sim::emoi {

struct SyntheticDsmConfig {
  double size_x_m = 200.0, size_y_m = 200.0;
  double resolution_m = 0.1;
  // hills
  double hill_amplitude_m = 6.0;          // amplitude of the largest octave
  double hill_wavelength_m = 80.0;        // largest octave's grid spacing
  int hill_octaves = 5;
  double hill_roughness = 0.5;            // amplitude ratio between octaves
  // objects
  int buildings = 40;
  std::array<double, 2> building_size_m{6.0, 20.0};
  std::array<double, 2> building_height_m{3.0, 15.0};
  int walls = 30;
  std::array<double, 2> wall_length_m{10.0, 40.0};
  std::array<double, 2> wall_height_m{1.5, 3.0};
  double wall_thickness_m = 0.3;
  int trees = 150;
  std::array<double, 2> tree_radius_m{1.5, 3.0};
  std::array<double, 2> tree_height_m{4.0, 9.0};
  double keep_clear_radius_m = 0.0;       // no object within this distance of `keep_clear` points
};

struct SyntheticWorld {
  locd::emoi::ElevationMap terrain;  // ground
  locd::emoi::ElevationMap surface;  // ground + buildings + walls + trees (the DSM)
};

// Parses a `world:` block (sizes, hills, buildings, walls, trees); errors name key and range.
SyntheticDsmConfig parse_world(const Params& world);

// keep_clear: points (map frame) no object may cover, e.g. the robot's path.
SyntheticWorld generate_world(const SyntheticDsmConfig& config, uint64_t seed,
                              const std::vector<Eigen::Vector2d>& keep_clear = {});

// The DSM a localizer is given: the surface plus Gaussian noise (seeded), optionally with
// nodata holes (fraction of cells in square patches).
locd::emoi::ElevationMap noisy_dsm(const locd::emoi::ElevationMap& surface, double noise_stddev_m,
                                   double nodata_fraction, uint64_t seed);

// Bilinear elevation at a map position (NaN outside).
double elevation_at(const locd::emoi::ElevationMap& map, const Eigen::Vector2d& position);

}  // namespace locd::sim::emoi
