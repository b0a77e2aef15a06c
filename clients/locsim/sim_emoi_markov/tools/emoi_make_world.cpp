// emoi_make_world SCENARIO.yaml SEED OUT.tif|OUT.yaml: writes the DSM a localizer gets for that
// scenario and seed (synthetic surface plus the scenario's DSM noise and nodata), as a GeoTIFF
// or as a 16-bit PNG with its YAML sidecar (1 cm steps).
#include <iostream>

#include "locd/emoi_markov/dsm_writer.hpp"
#include "locd/sim_emoi_markov/four_positions.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: emoi_make_world SCENARIO.yaml SEED OUT.tif|OUT.yaml\n";
    return 2;
  }
  try {
    const auto scenario = locd::sim::emoi::load_four_positions(argv[1]);
    const uint64_t seed = std::stoull(argv[2]);
    const auto run = locd::sim::emoi::build_run(scenario, seed);
    const std::filesystem::path out(argv[3]);
    if (out.extension() == ".yaml") {
      double low = 0, high = 0;
      cv::minMaxLoc(run.dsm.elevation, &low, &high);
      locd::emoi::write_dsm_png_with_sidecar(run.dsm, out, 0.01, std::floor(low) - 1.0);
    } else {
      locd::emoi::write_dsm_geotiff(run.dsm, out);
    }
    std::cout << "wrote " << out.string() << " (" << run.dsm.geometry.width << " x " << run.dsm.geometry.height
              << " cells of " << run.dsm.geometry.resolution << " m)\n";
  } catch (const std::exception& e) {
    std::cerr << "emoi_make_world: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
