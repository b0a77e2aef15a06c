// How much of a world's observable static structure the scans so far have seen. The reference
// (the denominator) is the observable surface, computed once per world: what virtual scans of
// the static world (people removed, no noise) from free, reachable grid positions at scanner
// height see. It holds voxels of `voxel_size` with a static hit between z_low and z_high (walls,
// doors' jambs and lintels, furniture; floor and ceiling slabs are left out, since a scanner
// reaching only 45 degrees down sees the floor in a ring under itself). A hit counts in the
// voxel just in front of the surface (the point moved 1 mm back toward the scanner): a face lying
// on a voxel boundary (the four-room world's walls are on the 0.2 m grid) is one voxel, not two
// voxels picked by rounding, one of them inside the wall. A scan covers the reference voxels its
// static hits fall in; moving people count for neither.
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
  // The voxel (packed key) a hit at `hit` seen from `sensor` counts in.
  int64_t surface_voxel(const Eigen::Vector3f& hit, const Eigen::Vector3f& sensor) const;
  // True when the voxel holding `point` is part of the reference.
  bool in_reference(const Eigen::Vector3f& point) const { return reference_.count(key(point)) > 0; }
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
