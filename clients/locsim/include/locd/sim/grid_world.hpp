// An occupancy grid as the simulated world: the map_server map a robot localizes in (or one made
// to differ from it) becomes the world it drives in. locsim's own ray cast, independent of any
// plugin's beam model:
//
// - A solid cell is a closed square, [col, col + 1] x [row, row + 1] times the resolution: the
//   range is the exact distance to where the ray first touches one (its face, or a corner it
//   passes through). A beam running exactly along a grid line touches the cells on both sides of
//   it; a beam through the corner where two diagonal solid cells meet stops there (no gap).
// - Solid: occupied (100), and map_server's grey (scale mode, 1..99) from 50 up: a cell closer to
//   occupied than to free is a surface the map's maker saw more often than not, and the world takes
//   the map at its word. Grey below 50, free (0) and unknown (-1) cells let the ray pass (a world
//   section of the scenario can put glass, clutter or missing walls where the map is wrong).
// - A ray starting inside a solid cell has range 0; outside the grid is empty space (a ray from
//   off the map may enter it); nothing within max_range: nullopt.
//
// The traversal is Amanatides & Woo's (1987) over cells, with ties (a corner) visiting both side
// cells.
#pragma once

#include <filesystem>
#include <memory>

#include "locd/sdk/occupancy_map.hpp"
#include "locd/sim/world.hpp"

namespace locd::sim {

class GridWorld : public RangeWorld {
 public:
  static constexpr int8_t kSolidFrom = 50;  // cell values >= this (up to 100) stop a ray

  explicit GridWorld(std::shared_ptr<const OccupancyMap> map);
  std::optional<double> cast(const Eigen::Vector2d& origin, double angle, double max_range) const override;
  const OccupancyMap& map() const { return *map_; }
  static bool solid(int8_t cell) { return cell >= kSolidFrom; }

 private:
  bool solid_at(int row, int col) const;
  std::shared_ptr<const OccupancyMap> map_;
};

// Whether a map YAML is in map_server's format (it names an `image`), not a feature map.
bool is_occupancy_map_yaml(const std::filesystem::path& yaml_file);

}  // namespace locd::sim
