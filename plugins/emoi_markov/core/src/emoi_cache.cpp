#include "locd/emoi_markov/emoi_cache.hpp"

#include <openssl/evp.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>

namespace fs = std::filesystem;

namespace locd::emoi {
namespace {

constexpr char kMagic[8] = {'L', 'O', 'C', 'D', 'E', 'M', 'O', '1'};
// Bump when the layers' definition changes, so old cache files are never read.
constexpr char kFormatTag[] = "locd emoi_markov layers v1: eq.7 / R^2, r in metres, nodata masked";

struct DigestDeleter {
  void operator()(EVP_MD_CTX* c) const { EVP_MD_CTX_free(c); }
};

}  // namespace

std::string cache_key(const ElevationMap& map, const std::vector<double>& radii_m) {
  std::unique_ptr<EVP_MD_CTX, DigestDeleter> context(EVP_MD_CTX_new());
  EVP_DigestInit_ex(context.get(), EVP_sha256(), nullptr);
  auto feed = [&](const void* data, size_t bytes) { EVP_DigestUpdate(context.get(), data, bytes); };
  feed(kFormatTag, sizeof(kFormatTag));
  const int32_t size[2] = {map.geometry.width, map.geometry.height};
  feed(size, sizeof(size));
  const double geometry[3] = {map.geometry.resolution, map.geometry.origin.x(), map.geometry.origin.y()};
  feed(geometry, sizeof(geometry));
  const uint64_t radius_count = radii_m.size();
  feed(&radius_count, sizeof(radius_count));
  feed(radii_m.data(), radii_m.size() * sizeof(double));
  const float canonical_nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> row(map.geometry.width);
  for (int r = 0; r < map.geometry.height; ++r) {
    const float* src = map.elevation.ptr<float>(r);
    for (int c = 0; c < map.geometry.width; ++c) row[c] = std::isfinite(src[c]) ? src[c] : canonical_nan;
    feed(row.data(), row.size() * sizeof(float));
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  EVP_DigestFinal_ex(context.get(), digest, &length);
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < length; ++i) {
    out += hex[digest[i] >> 4];
    out += hex[digest[i] & 15];
  }
  return out;
}

fs::path default_cache_directory() {
  if (const char* dir = std::getenv("LOCD_CACHE_DIR"); dir && *dir) return fs::path(dir) / "emoi_markov";
  if (const char* dir = std::getenv("XDG_CACHE_HOME"); dir && *dir) return fs::path(dir) / "locd" / "emoi_markov";
  if (const char* home = std::getenv("HOME"); home && *home) return fs::path(home) / ".cache" / "locd" / "emoi_markov";
  return fs::temp_directory_path() / "locd" / "emoi_markov";
}

fs::path EmoiCache::file_for(const std::string& key) const { return directory_ / (key + ".emoi"); }

std::optional<EmoiLayers> EmoiCache::load(const std::string& key, const ElevationMap& map) const {
  std::ifstream in(file_for(key), std::ios::binary);
  if (!in) return std::nullopt;
  char magic[8];
  char stored_key[64];
  int32_t width = 0, height = 0;
  uint64_t count = 0;
  in.read(magic, sizeof(magic));
  in.read(stored_key, sizeof(stored_key));
  in.read(reinterpret_cast<char*>(&width), sizeof(width));
  in.read(reinterpret_cast<char*>(&height), sizeof(height));
  in.read(reinterpret_cast<char*>(&count), sizeof(count));
  if (!in || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0 || key.size() != sizeof(stored_key) ||
      std::memcmp(stored_key, key.data(), sizeof(stored_key)) != 0 || width != map.geometry.width ||
      height != map.geometry.height || count == 0 || count > 64) {
    return std::nullopt;
  }
  EmoiLayers layers;
  layers.radii_m.resize(count);
  in.read(reinterpret_cast<char*>(layers.radii_m.data()), count * sizeof(double));
  for (uint64_t i = 0; i < count; ++i) {
    cv::Mat_<float> layer(height, width);
    in.read(reinterpret_cast<char*>(layer.ptr<float>(0)), static_cast<std::streamsize>(layer.total() * sizeof(float)));
    layers.layers.push_back(layer);
  }
  if (!in) return std::nullopt;
  return layers;
}

bool EmoiCache::store(const std::string& key, const EmoiLayers& layers) const {
  std::error_code error;
  fs::create_directories(directory_, error);
  if (error || key.size() != 64 || layers.layers.empty()) return false;
  std::random_device entropy;
  const fs::path temporary = directory_ / (key + ".tmp" + std::to_string(entropy()));
  {
    std::ofstream out(temporary, std::ios::binary);
    const int32_t width = layers.layers[0].cols, height = layers.layers[0].rows;
    const uint64_t count = layers.layers.size();
    out.write(kMagic, sizeof(kMagic));
    out.write(key.data(), 64);
    out.write(reinterpret_cast<const char*>(&width), sizeof(width));
    out.write(reinterpret_cast<const char*>(&height), sizeof(height));
    out.write(reinterpret_cast<const char*>(&count), sizeof(count));
    out.write(reinterpret_cast<const char*>(layers.radii_m.data()), count * sizeof(double));
    for (const auto& layer : layers.layers) {
      const cv::Mat_<float> contiguous = layer.isContinuous() ? layer : layer.clone();
      out.write(reinterpret_cast<const char*>(contiguous.ptr<float>(0)),
                static_cast<std::streamsize>(contiguous.total() * sizeof(float)));
    }
    if (!out) {
      fs::remove(temporary, error);
      return false;
    }
  }
  fs::rename(temporary, file_for(key), error);
  if (error) fs::remove(temporary, error);
  return !error;
}

LayersSource load_or_compute_layers(const ElevationMap& map, const std::vector<double>& radii_m,
                                    const std::optional<fs::path>& cache_directory, const ProgressCallback& progress) {
  LayersSource source;
  source.key = cache_key(map, radii_m);
  if (cache_directory) {
    EmoiCache cache(*cache_directory);
    if (auto layers = cache.load(source.key, map)) {
      source.layers = std::move(*layers);
      source.from_cache = true;
      return source;
    }
  }
  source.layers = to_layers(radii_m, emoi_fft(map, radii_m, progress));
  if (cache_directory) EmoiCache(*cache_directory).store(source.key, source.layers);
  return source;
}

}  // namespace locd::emoi
