// Writes the occupancy grids grid_mcl's scenarios run on, in map_server's format:
//   locd_grid_world corridor config/maps/corridor.yaml config/maps/corridor_grid.yaml   (PGM)
//   locd_grid_world warehouse config/maps/warehouse.yaml                                  (PNG)
// The corridor: the feature map's walls at 0.05 m, free where the robot can drive from its start
// (3, 1), unknown elsewhere. The warehouse: 100 x 100 m at 0.05 m (grid_worlds.hpp); PNG because
// its 4.5 M cells are 4.5 MB as a PGM and about 60 kB as a PNG.
#include <iostream>
#include <string>

#include "locd/sim_grid_mcl/grid_worlds.hpp"

int main(int argc, char** argv) {
  using namespace locd;
  const std::string what = argc > 1 ? argv[1] : "";
  try {
    if (what == "corridor" && argc == 4) {
      const FeatureMap2D walls = load_feature_map(argv[2], 100000);
      save_occupancy_map(sim::grid::rasterize_walls(walls, 0.05, 1.0, Eigen::Vector2d(3.0, 1.0)), argv[3], ".pgm");
      return 0;
    }
    if (what == "warehouse" && argc == 3) {
      save_occupancy_map(sim::grid::make_warehouse(), argv[2], ".png");
      return 0;
    }
  } catch (const std::exception& e) {
    std::cerr << "locd_grid_world: " << e.what() << "\n";
    return 1;
  }
  std::cerr << "usage: locd_grid_world corridor FEATURE_MAP.yaml OUT.yaml | locd_grid_world warehouse OUT.yaml\n";
  return 2;
}
