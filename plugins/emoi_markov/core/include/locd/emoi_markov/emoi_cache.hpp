// On-disk cache of EMOI layers, keyed by the SHA-256 of the map content (geometry and every
// elevation) and the radii: the same DSM and radii are computed once per machine.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "locd/emoi_markov/emoi.hpp"

namespace locd::emoi {

// Hex SHA-256 over a format tag, the geometry, the radii and the elevation bytes.
std::string cache_key(const ElevationMap& map, const std::vector<double>& radii_m);

// $LOCD_CACHE_DIR/emoi_markov, else $XDG_CACHE_HOME/locd/emoi_markov, else
// $HOME/.cache/locd/emoi_markov. Never a path from a (remote) config.
std::filesystem::path default_cache_directory();

class EmoiCache {
 public:
  explicit EmoiCache(std::filesystem::path directory) : directory_(std::move(directory)) {}
  std::optional<EmoiLayers> load(const std::string& key, const ElevationMap& map) const;
  // Writes atomically (temporary file, then rename). False (and no file) on an I/O failure.
  bool store(const std::string& key, const EmoiLayers& layers) const;
  std::filesystem::path file_for(const std::string& key) const;

 private:
  std::filesystem::path directory_;
};

// Layers from the cache when present, else computed with emoi_fft and stored.
struct LayersSource {
  EmoiLayers layers;
  bool from_cache = false;
  std::string key;
};
LayersSource load_or_compute_layers(const ElevationMap& map, const std::vector<double>& radii_m,
                                    const std::optional<std::filesystem::path>& cache_directory,
                                    const ProgressCallback& progress = {});

}  // namespace locd::emoi
