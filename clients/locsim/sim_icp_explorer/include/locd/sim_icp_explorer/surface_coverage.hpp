// How much of a world's observable static structure the scans so far have seen. The reference is
// what dense virtual scans from every free grid position would see (voxels of `voxel_size`
// holding a static hit between z_low and z_high: walls, doors' jambs and lintels, furniture;
// floor and ceiling slabs are left out, since a scanner reaching only 45 degrees down sees the
// floor in a ring under itself); a scan covers the reference voxels its static hits fall in.
// Moving people count for neither.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <unordered_set>
#include <vector>

#include "locd/sim_icp_explorer/indoor_world.hpp"
#include "locd/sim_icp_explorer/scanner3d.hpp"

namespace locd::sim {

class SurfaceCoverage {
 public:
  // Reference from virtual scans (reference_scanner, no noise) at the grid_step positions whose
  // footprint (robot_radius) is free and that are reachable by 4-connected steps from `start`;
  // every scan_every-th of them in x and y is scanned.
  SurfaceCoverage(const IndoorWorld& world, const Scanner3DConfig& reference_scanner, double voxel_size,
                  double grid_step, double robot_radius, const Eigen::Vector2d& start, int scan_every = 1,
                  double z_low = 0.05, double z_high = 2.5);

  void add(const SimulatedScan& scan, const IndoorWorld& world);
  double ratio() const;  // covered reference voxels / reference voxels
  size_t reference_voxels() const { return reference_.size(); }
  size_t covered_voxels() const { return covered_.size(); }
  // The free, reachable grid positions the reference was built from (scanned or not).
  const std::vector<Eigen::Vector2d>& reachable_positions() const { return positions_; }

 private:
  int64_t key(const Eigen::Vector3f& p) const;
  bool counted(const Eigen::Vector3f& p) const { return p.z() >= z_low_ && p.z() <= z_high_; }
  double voxel_size_;
  double z_low_, z_high_;
  std::unordered_set<int64_t> reference_;
  std::unordered_set<int64_t> covered_;
  std::vector<Eigen::Vector2d> positions_;
};

}  // namespace locd::sim
