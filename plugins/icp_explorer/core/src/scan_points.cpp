#include "locd/icp_explorer/scan_points.hpp"

#include <cmath>
#include <cstdint>
#include <limits>

#include "locd/icp_explorer/voxel_key.hpp"

namespace locd::icp_explorer {

ScanPoints voxel_downsample(const std::vector<Eigen::Vector3f>& points, const std::vector<float>& intensity,
                            double voxel_size, const Eigen::Isometry3d& transform) {
  struct Accumulator {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double intensity = 0.0;
    int count = 0;
  };
  const bool with_intensity = intensity.size() == points.size() && !points.empty();
  // Open addressing (linear probing) over a power-of-two table at most half full: a scan is
  // downsampled once per registration, and std::unordered_map's node allocations were a tenth
  // of the registration time.
  int bits = 6;
  while ((size_t{1} << bits) < 2 * points.size()) ++bits;
  const size_t capacity = size_t{1} << bits, mask = capacity - 1;
  std::vector<VoxelKey> keys(capacity);
  std::vector<uint32_t> slots(capacity, std::numeric_limits<uint32_t>::max());
  std::vector<Accumulator> voxels;
  voxels.reserve(points.size() / 4 + 16);
  const VoxelKeyHash hash;
  const double inverse = 1.0 / voxel_size;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    const Eigen::Vector3d p = transform * points[i].cast<double>();
    const VoxelKey key = voxel_key(p, inverse);
    size_t slot = static_cast<size_t>((static_cast<uint64_t>(hash(key)) * 0x9E3779B97F4A7C15ull) >> (64 - bits));
    while (slots[slot] != std::numeric_limits<uint32_t>::max() && keys[slot] != key) slot = (slot + 1) & mask;
    if (slots[slot] == std::numeric_limits<uint32_t>::max()) {
      slots[slot] = static_cast<uint32_t>(voxels.size());
      keys[slot] = key;
      voxels.emplace_back();
    }
    Accumulator& a = voxels[slots[slot]];
    a.sum += p;
    if (with_intensity) a.intensity += intensity[i];
    ++a.count;
  }
  ScanPoints out;
  out.points.reserve(voxels.size());
  if (with_intensity) out.intensity.reserve(voxels.size());
  for (const Accumulator& a : voxels) {
    out.points.push_back(a.sum / a.count);
    if (with_intensity) out.intensity.push_back(static_cast<float>(a.intensity / a.count));
  }
  return out;
}

ScanPoints transformed(const ScanPoints& scan, const Eigen::Isometry3d& transform) {
  ScanPoints out = scan;
  for (auto& p : out.points) p = transform * p;
  return out;
}

}  // namespace locd::icp_explorer
