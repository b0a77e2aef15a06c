// emoi_precompute DSM [radius_m ...]: computes the EMOI layers of a DSM file with a progress bar
// and stores them in the on-disk cache the plugin reads (default radii 5 10 15 m).
#include <chrono>
#include <iostream>

#include "locd/emoi_markov/emoi_cache.hpp"
#include "locd/emoi_markov/progress.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sdk/plugin.hpp"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: emoi_precompute DSM.tif|DSM.yaml [radius_m ...]\n";
    return 2;
  }
  std::vector<double> radii;
  for (int i = 2; i < argc; ++i) radii.push_back(std::stod(argv[i]));
  if (radii.empty()) radii = {5.0, 10.0, 15.0};
  try {
    const auto map = locd::emoi::load_dsm(argv[1], locd::Limits{}.max_map_cells);
    std::cout << argv[1] << ": " << map.geometry.width << " x " << map.geometry.height << " cells of "
              << map.geometry.resolution << " m\n";
    locd::emoi::ProgressBar bar(std::cerr);
    const auto start = std::chrono::steady_clock::now();
    const auto directory = locd::emoi::default_cache_directory();
    const auto source = locd::emoi::load_or_compute_layers(
        map, radii, directory, [&](double f, const std::string& stage) { bar.update(f, stage); });
    bar.finish();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << (source.from_cache ? "already cached: " : "computed and cached: ")
              << locd::emoi::EmoiCache(directory).file_for(source.key).string() << " (" << seconds << " s)\n";
  } catch (const std::exception& e) {
    std::cerr << "emoi_precompute: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
