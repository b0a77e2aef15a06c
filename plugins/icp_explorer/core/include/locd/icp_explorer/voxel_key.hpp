// Integer voxel coordinates of a point and a hash for them.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace locd::icp_explorer {

using VoxelKey = Eigen::Vector3i;

inline VoxelKey voxel_key(const Eigen::Vector3d& p, double inverse_voxel_size) {
  return {static_cast<int>(std::floor(p.x() * inverse_voxel_size)),
          static_cast<int>(std::floor(p.y() * inverse_voxel_size)),
          static_cast<int>(std::floor(p.z() * inverse_voxel_size))};
}

struct VoxelKeyHash {
  size_t operator()(const VoxelKey& k) const {
    return static_cast<size_t>((static_cast<uint64_t>(static_cast<uint32_t>(k.x())) * 73856093u) ^
                               (static_cast<uint64_t>(static_cast<uint32_t>(k.y())) * 19349663u) ^
                               (static_cast<uint64_t>(static_cast<uint32_t>(k.z())) * 83492791u));
  }
};

}  // namespace locd::icp_explorer
