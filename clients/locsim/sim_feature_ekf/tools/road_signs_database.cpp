// Prints the landmark database (CSV) of a scenario's world:
//   locd_road_signs_database config/scenarios/road_signs.yaml > config/maps/road_signs.csv
#include <iostream>

#include "locd/sdk/errors.hpp"
#include "locd/sim_feature_ekf/road_sign_world.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: locd_road_signs_database SCENARIO.yaml\n";
    return 2;
  }
  try {
    const locd::Params scenario = locd::Params::load_file(argv[1]);
    const locd::sim::road_signs::RoadSignWorld world(
        locd::sim::road_signs::WorldConfig::from_params(scenario.child("world")));
    std::cout << world.database_csv();
  } catch (const std::exception& e) {
    std::cerr << "locd_road_signs_database: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
