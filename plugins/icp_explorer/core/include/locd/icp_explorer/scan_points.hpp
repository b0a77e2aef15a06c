// Points of one scan after preprocessing: positions (double, for the solver) and, when the
// scanner reports it, intensity per point. Voxel downsampling keeps one centroid per voxel.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace locd::icp_explorer {

struct ScanPoints {
  std::vector<Eigen::Vector3d> points;
  std::vector<float> intensity;  // empty, or one per point

  bool has_intensity() const { return !intensity.empty(); }
  size_t size() const { return points.size(); }
};

// One point per occupied voxel of edge voxel_size: the centroid of the points in it (and their
// mean intensity), after applying `transform` to every point. Non-finite points are skipped.
ScanPoints voxel_downsample(const std::vector<Eigen::Vector3f>& points, const std::vector<float>& intensity,
                            double voxel_size, const Eigen::Isometry3d& transform = Eigen::Isometry3d::Identity());

ScanPoints transformed(const ScanPoints& scan, const Eigen::Isometry3d& transform);

}  // namespace locd::icp_explorer
