#include "locd/grid_mcl/shared_map.hpp"

#include <cmath>
#include <future>
#include <limits>
#include <map>
#include <mutex>
#include <tuple>

namespace locd::grid_mcl {

namespace fs = std::filesystem;

namespace {

// One row or column of F&H's 1D squared distance transform: d(q) = min_p (q - p)^2 + f(p).
void squared_distance_1d(const std::vector<double>& f, std::vector<double>& d, std::vector<int>& v,
                         std::vector<double>& z) {
  const int n = static_cast<int>(f.size());
  constexpr double kInf = std::numeric_limits<double>::infinity();
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (f[q] == kInf) continue;
    double s = 0.0;
    while (k >= 0) {
      s = ((f[q] + double(q) * q) - (f[v[k]] + double(v[k]) * v[k])) / (2.0 * q - 2.0 * v[k]);
      if (s > z[k]) break;
      --k;
    }
    ++k;
    v[k] = q;
    z[k] = k == 0 ? -kInf : s;
    z[k + 1] = kInf;
  }
  if (k < 0) {
    std::fill(d.begin(), d.end(), kInf);
    return;
  }
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (z[j + 1] < q) ++j;
    const double dq = q - v[j];
    d[q] = dq * dq + f[v[j]];
  }
}

}  // namespace

DistanceField::DistanceField(const OccupancyMap& map)
    : width_(map.geometry().width), step_(map.geometry().resolution / kSubdivision) {
  const int w = map.geometry().width, h = map.geometry().height;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::vector<double> squared(static_cast<size_t>(w) * h);
  const int longest = std::max(w, h);
  std::vector<double> f(longest), d(longest), z(longest + 1);
  std::vector<int> v(longest);
  // Columns, then rows.
  f.resize(h);
  d.resize(h);
  for (int c = 0; c < w; ++c) {
    for (int r = 0; r < h; ++r) f[r] = map.occupied(r, c) ? 0.0 : kInf;
    squared_distance_1d(f, d, v, z);
    for (int r = 0; r < h; ++r) squared[static_cast<size_t>(r) * w + c] = d[r];
  }
  f.resize(w);
  d.resize(w);
  cells_.resize(squared.size());
  for (int r = 0; r < h; ++r) {
    std::copy(squared.begin() + static_cast<std::ptrdiff_t>(r) * w, squared.begin() + static_cast<std::ptrdiff_t>(r + 1) * w,
              f.begin());
    squared_distance_1d(f, d, v, z);
    for (int c = 0; c < w; ++c) {
      const double units = std::sqrt(d[c]) * kSubdivision;
      const uint16_t distance = units >= kSaturated ? kSaturated : static_cast<uint16_t>(std::lround(units));
      cells_[static_cast<size_t>(r) * w + c] = map.at(r, c) == OccupancyMap::kUnknown ? distance | kUnknownBit : distance;
    }
  }
}

double brute_force_distance(const OccupancyMap& map, int row, int col) {
  double best = std::numeric_limits<double>::infinity();
  const GridGeometry& g = map.geometry();
  for (int r = 0; r < g.height; ++r) {
    for (int c = 0; c < g.width; ++c) {
      if (!map.occupied(r, c)) continue;
      best = std::min(best, std::hypot(r - row, c - col) * g.resolution);
    }
  }
  return best;
}

size_t SharedMap::memory_bytes() const {
  return sizeof(SharedMap) + map.cells().capacity() * sizeof(int8_t) + field.cells().capacity() * sizeof(uint16_t);
}

namespace {

struct FileVersion {
  std::string path;
  int64_t modified = 0;
  uintmax_t size = 0;
  bool operator<(const FileVersion& o) const { return std::tie(path, modified, size) < std::tie(o.path, o.modified, o.size); }
};

FileVersion version_of(const fs::path& file) {
  std::error_code ec;
  FileVersion v;
  v.path = fs::weakly_canonical(file, ec).string();
  if (ec) v.path = file.string();
  const auto time = fs::last_write_time(file, ec);
  if (!ec) v.modified = static_cast<int64_t>(time.time_since_epoch().count());
  v.size = fs::file_size(file, ec);
  if (ec) v.size = 0;
  return v;
}

using Key = std::pair<FileVersion, FileVersion>;  // YAML, image

struct Cache {
  std::mutex mutex;
  // A load in progress is a shared_future others wait on; a loaded map a weak_ptr.
  std::map<Key, std::shared_future<std::shared_ptr<const SharedMap>>> loading;
  std::map<Key, std::weak_ptr<const SharedMap>> loaded;
};

Cache& cache() {
  static Cache c;
  return c;
}

}  // namespace

std::shared_ptr<const SharedMap> load_shared_map(const fs::path& yaml_file, const ImageResolver& resolve_image,
                                                 size_t max_cells) {
  MapYaml yaml = read_map_yaml(yaml_file, resolve_image);
  const Key key{version_of(yaml_file), version_of(yaml.image_file)};
  Cache& c = cache();
  std::promise<std::shared_ptr<const SharedMap>> promise;
  {
    std::unique_lock<std::mutex> lock(c.mutex);
    for (auto it = c.loaded.begin(); it != c.loaded.end();) it = it->second.expired() ? c.loaded.erase(it) : std::next(it);
    if (auto it = c.loaded.find(key); it != c.loaded.end()) {
      if (auto held = it->second.lock()) return held;
    }
    if (auto it = c.loading.find(key); it != c.loading.end()) {
      auto pending = it->second;
      lock.unlock();
      return pending.get();  // rethrows the loader's error
    }
    c.loading.emplace(key, promise.get_future().share());
  }
  std::shared_ptr<const SharedMap> result;
  try {
    auto shared = std::make_shared<SharedMap>();
    shared->map = occupancy_from_image(yaml, read_map_image(yaml.image_file, max_cells));
    shared->field = DistanceField(shared->map);
    shared->yaml = std::move(yaml);
    result = std::move(shared);
    promise.set_value(result);
  } catch (...) {
    promise.set_exception(std::current_exception());
    std::lock_guard<std::mutex> lock(c.mutex);
    c.loading.erase(key);
    throw;
  }
  std::lock_guard<std::mutex> lock(c.mutex);
  c.loading.erase(key);
  c.loaded[key] = result;
  return result;
}

size_t shared_maps_alive() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  size_t alive = 0;
  for (const auto& [key, entry] : c.loaded) alive += !entry.expired();
  return alive;
}

}  // namespace locd::grid_mcl
