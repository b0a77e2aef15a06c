#include "locd/sim/grid_world.hpp"

#include <yaml-cpp/yaml.h>

namespace locd::sim {

GridWorld::GridWorld(std::shared_ptr<const grid_mcl::OccupancyMap> map) : map_(std::move(map)) {}

std::optional<double> GridWorld::cast(const Eigen::Vector2d& origin, double angle, double max_range) const {
  return map_->cast(origin, angle, max_range, false);
}

bool is_occupancy_map_yaml(const std::filesystem::path& yaml_file) {
  try {
    const YAML::Node node = YAML::LoadFile(yaml_file.string());
    return node.IsMap() && node["image"].IsDefined();
  } catch (const YAML::Exception&) {
    return false;  // the feature-map loader reports what is wrong
  }
}

}  // namespace locd::sim
