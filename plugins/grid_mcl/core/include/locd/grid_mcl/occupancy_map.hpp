// grid_mcl's map is the sdk's occupancy grid in map_server's format (locd/sdk/occupancy_map.hpp);
// what is grid_mcl's own is how its beam model casts a ray on it.
#pragma once

#include <Eigen/Core>
#include <optional>

#include "locd/sdk/occupancy_map.hpp"

namespace locd::grid_mcl {

using locd::ImageResolver;
using locd::load_occupancy_map;
using locd::MapImage;
using locd::MapMode;
using locd::MapYaml;
using locd::OccupancyMap;
using locd::occupancy_from_image;
using locd::read_map_image;
using locd::read_map_yaml;
using locd::save_occupancy_map;

// Distance from origin along the ray at `angle` (map frame) to the first occupied cell (with
// stop_at_unknown also an unknown cell or the map's edge, as AMCL's beam model), traversing
// the cells the ray crosses (Amanatides & Woo). An occupied cell stands for a surface through
// its centre (as the likelihood field and AMCL's beam model measure): the range is to the
// ray's point nearest that centre, kept within the ray's stretch inside the cell. nullopt
// beyond max_range.
std::optional<double> cast(const OccupancyMap& map, const Eigen::Vector2d& origin, double angle, double max_range,
                           bool stop_at_unknown = false);

}  // namespace locd::grid_mcl
