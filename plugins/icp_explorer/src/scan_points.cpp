#include "locd/icp_explorer/scan_points.hpp"

#include <cmath>
#include <unordered_map>

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
  std::unordered_map<VoxelKey, uint32_t, VoxelKeyHash> index;
  index.reserve(points.size() / 2 + 16);
  std::vector<Accumulator> voxels;
  voxels.reserve(points.size() / 2 + 16);
  const double inverse = 1.0 / voxel_size;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    const Eigen::Vector3d p = transform * points[i].cast<double>();
    const auto [it, inserted] = index.try_emplace(voxel_key(p, inverse), static_cast<uint32_t>(voxels.size()));
    if (inserted) voxels.emplace_back();
    Accumulator& a = voxels[it->second];
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
