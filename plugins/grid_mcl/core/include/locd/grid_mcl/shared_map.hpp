// What every session on one map shares: the occupancy grid and its distance field, loaded once
// per process and file version.
//
// DistanceField: for every cell the Euclidean distance from its centre to the nearest occupied
// cell's centre, exact (Felzenszwalb & Huttenlocher, "Distance Transforms of Sampled
// Functions", 2012: the lower envelope of parabolas, by columns then rows), stored in 12 bits in
// 1/16 of a cell (3 mm at 0.05 m cells), saturating at 4095 (255 cells: 12.8 m at 0.05 m cells,
// beyond any field's laser_likelihood_max_dist of interest); the 13th bit says the map's cell is
// unknown. The likelihood field's per-session table (sigma_hit, z_hit, z_rand,
// laser_likelihood_max_dist, unknown_occupancy) is indexed by that code as it is, so sessions
// with different parameters share one field.
//
// load_shared_map keeps a process-wide cache keyed by the YAML's and the image's canonical paths,
// modification times and sizes; entries are weak_ptrs, so a map leaves memory with its last
// session, and a changed file is loaded afresh. Plugins that run in worker processes share per
// process.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "locd/grid_mcl/occupancy_map.hpp"

namespace locd::grid_mcl {

class DistanceField {
 public:
  static constexpr int kSubdivision = 16;  // units per cell
  static constexpr uint16_t kSaturated = 0x0FFF;
  static constexpr uint16_t kUnknownBit = 0x1000;  // the map's cell is unknown
  static constexpr size_t kCodes = 0x2000;         // distinct codes: distances, known or unknown

  DistanceField() = default;
  explicit DistanceField(const OccupancyMap& map);

  uint16_t at(int row, int col) const { return cells_[static_cast<size_t>(row) * width_ + col] & kSaturated; }
  double distance(int row, int col) const { return at(row, col) * step_; }  // m
  // Per cell the distance in units, with kUnknownBit set where the map's cell is unknown.
  const std::vector<uint16_t>& cells() const { return cells_; }
  double step() const { return step_; }  // m per unit

 private:
  int width_ = 0;
  double step_ = 0.0;
  std::vector<uint16_t> cells_;
};

// The reference: nearest occupied cell centre by scanning every occupied cell (m, unquantised;
// infinity without any occupied cell).
double brute_force_distance(const OccupancyMap& map, int row, int col);

struct SharedMap {
  MapYaml yaml;
  OccupancyMap map;
  DistanceField field;
  size_t memory_bytes() const;  // cells, field and this struct
};

std::shared_ptr<const SharedMap> load_shared_map(const std::filesystem::path& yaml_file, const ImageResolver& resolve_image,
                                                 size_t max_cells);
// Maps currently held by some session in this process (tests, diagnostics).
size_t shared_maps_alive();

}  // namespace locd::grid_mcl
