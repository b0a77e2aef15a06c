// An occupancy grid as the simulated world: the map_server map a robot localizes in becomes the
// world it drives in. A ray stops where it enters an occupied cell (grid_mcl's OccupancyMap::cast,
// the same traversal its beam model uses); free and unknown cells let it pass.
#pragma once

#include <filesystem>
#include <memory>

#include "locd/grid_mcl/occupancy_map.hpp"
#include "locd/sim/world.hpp"

namespace locd::sim {

class GridWorld : public RangeWorld {
 public:
  explicit GridWorld(std::shared_ptr<const grid_mcl::OccupancyMap> map);
  std::optional<double> cast(const Eigen::Vector2d& origin, double angle, double max_range) const override;
  const grid_mcl::OccupancyMap& map() const { return *map_; }

 private:
  std::shared_ptr<const grid_mcl::OccupancyMap> map_;
};

// Whether a map YAML is in map_server's format (it names an `image`), not a feature map.
bool is_occupancy_map_yaml(const std::filesystem::path& yaml_file);

}  // namespace locd::sim
