// locd_ceiling_world_map SCENARIO.yaml > MAP.yaml
// Prints the landmark map of the world in SCENARIO's sensors.ceiling_camera.world, the file
// ceiling_pf's config names (config/maps/ceiling_hall.yaml is made this way).
#include <iostream>

#include "locd/sdk/errors.hpp"
#include "locd/sim_ceiling_pf/ceiling_world.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: locd_ceiling_world_map SCENARIO.yaml > MAP.yaml\n";
    return 2;
  }
  try {
    const locd::Params scenario = locd::Params::load_file(argv[1]);
    const locd::Params world = scenario.child("sensors").child("ceiling_camera").child("world");
    std::cout << locd::sim::ceiling::CeilingWorld(locd::sim::ceiling::CeilingWorldConfig::from_params(world)).map_yaml();
  } catch (const std::exception& e) {
    std::cerr << "locd_ceiling_world_map: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
