// The global model: a voxel map in the map frame. Each voxel keeps the running centroid and mean
// intensity of every point that fell in it; a kd-tree (nanoflann) over the centroids answers
// nearest-neighbour queries, and each centroid has a normal from its k nearest neighbours (for
// point-to-plane ICP). Inserting a scan rebuilds the tree and refreshes the touched normals.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "locd/icp_explorer/scan_points.hpp"
#include "locd/icp_explorer/voxel_key.hpp"

namespace locd::icp_explorer {

class VoxelMap {
 public:
  explicit VoxelMap(double voxel_size, int normal_neighbours = 10);
  ~VoxelMap();
  VoxelMap(VoxelMap&&) noexcept;
  VoxelMap& operator=(VoxelMap&&) noexcept;

  // viewpoint: the scanner position of this scan; the touched normals are turned to face it
  // (a surface faces the scanners that see it), which lets ICP skip back faces of thin walls.
  void insert(const ScanPoints& points_in_map, const std::optional<Eigen::Vector3d>& viewpoint = std::nullopt);
  void clear();
  // Free-space carving against moving objects' ghosts: a voxel hit in a single earlier scan is
  // removed when at least `min_rays` rays of a new scan (from `viewpoint` to `ray_ends`, map
  // frame) see through it: each crosses the voxel, ends more than `end_margin` beyond it, does
  // not graze the voxel's surface (|normal . ray| >= 0.3), does not end on that surface's plane,
  // and crosses the plane within 0.3 voxel of the centroid (a ray passing beside an object's
  // edge crosses the edge voxel but not the surface). Only voxels with a normal are carved (the
  // floor's sparse far rings have none). Call before inserting that scan. Returns how many.
  size_t carve(const std::vector<Eigen::Vector3d>& ray_ends, const Eigen::Vector3d& viewpoint, int min_rays = 2,
               double end_margin = 0.25);
  // Scans that hit voxel i.
  int scans_seen(size_t i) const { return scans_[i]; }
  // The insert (0 for the first insert() after construction or clear(), 1 for the next, ...) that
  // created voxel i: its position is anchored by that scan's pose.
  uint32_t first_insert(size_t i) const { return first_insert_[i]; }
  uint32_t inserts() const { return inserts_; }

  bool empty() const { return points_.empty(); }
  size_t size() const { return points_.size(); }
  double voxel_size() const { return voxel_size_; }
  const std::vector<Eigen::Vector3d>& points() const { return points_; }
  const std::vector<Eigen::Vector3d>& normals() const { return normals_; }  // unit, facing the scanners; zero when undefined
  const std::vector<float>& intensity() const { return intensity_; }       // NaN where no intensity came
  bool has_intensity(size_t i) const { return intensity_count_[i] > 0; }
  // True when every insert came with its viewpoint, so normals face the scanners.
  bool normals_face_scanners() const { return normals_oriented_; }

  // Nearest centroid to q: false when the map is empty.
  bool nearest(const Eigen::Vector3d& q, size_t& index, double& distance2) const;
  // The two nearest centroids closer than sqrt(bound2), nearest first: returns how many there
  // are (0, 1 or 2); distance2[k] of a missing one is bound2. A tight bound prunes the search.
  size_t nearest_two_within(const Eigen::Vector3d& q, double bound2, size_t index[2], double distance2[2]) const;

  // The model thinned to one point per voxel of `voxel_size` (publishing, saving).
  ScanPoints downsampled(double voxel_size) const;

 private:
  struct KdTree;
  void refresh_normals(const std::vector<uint32_t>& touched, const std::optional<Eigen::Vector3d>& viewpoint);

  double voxel_size_;
  double inverse_voxel_size_;
  int normal_neighbours_;
  std::unordered_map<VoxelKey, uint32_t, VoxelKeyHash> index_;
  std::vector<Eigen::Vector3d> sums_;
  std::vector<int> counts_;
  std::vector<uint16_t> scans_;  // inserts that touched the voxel
  std::vector<uint32_t> first_insert_;
  uint32_t inserts_ = 0;
  std::vector<double> intensity_sums_;
  std::vector<int> intensity_count_;
  std::vector<Eigen::Vector3d> points_;
  std::vector<Eigen::Vector3d> normals_;
  std::vector<float> intensity_;
  std::unique_ptr<KdTree> tree_;
  bool normals_oriented_ = true;
};

}  // namespace locd::icp_explorer
