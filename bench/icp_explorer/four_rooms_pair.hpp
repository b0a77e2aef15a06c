// The registration pair of the benchmarks: in the four-room world, a model built from two
// scans at known poses and a full-size (about 100k points) scan from a third pose, with the
// initial guess off by odometry error within the bounds.
#pragma once

#include <random>
#include <string>

#include "locd/icp_explorer/icp_explorer.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sim_icp_explorer/indoor_world.hpp"
#include "locd/sim_icp_explorer/scanner3d.hpp"

namespace locd::bench {

inline std::string source_dir() {
  const char* s = std::getenv("LOCD_SOURCE_DIR");
  return s ? s : LOCD_SOURCE_DIR_DEFAULT;
}

struct RegistrationPair {
  sim::IndoorWorld world;
  sim::Scanner3D scanner;
  icp_explorer::VoxelMap model;
  icp_explorer::VoxelMap coarse_model;   // the same scans at the coarse stage's voxel size
  PointCloud scan;                       // the new scan, sensor frame
  Eigen::Isometry3d truth;               // its base_link pose in the map
  Eigen::Isometry3d initial;             // odometry prediction
};

inline RegistrationPair make_pair(double map_voxel_size = 0.1, double translation_error = 0.4,
                                  double yaw_error_deg = 8.0) {
  RegistrationPair pair{sim::IndoorWorld::load(source_dir() + "/config/maps/four_rooms_3d.yaml"),
                        sim::Scanner3D(sim::Scanner3DConfig{}),
                        icp_explorer::VoxelMap(map_voxel_size),
                        icp_explorer::VoxelMap(icp_explorer::CoarseStageSettings{}.voxel_size),
                        {},
                        {},
                        {}};
  std::mt19937_64 rng(42);
  for (const Pose2& stop : {Pose2(4.0, 2.5, 0.2), Pose2(4.0, 6.0, -0.4)}) {
    const Eigen::Isometry3d T = stop.to_isometry();
    const auto s = pair.scanner.scan(pair.world, T, 0.0, 0, rng);
    const auto dense = icp_explorer::voxel_downsample(s.cloud.points, s.cloud.intensity, map_voxel_size,
                                                      T * s.cloud.sensor_pose);
    pair.model.insert(dense, (T * s.cloud.sensor_pose).translation());
    pair.coarse_model.insert(dense, (T * s.cloud.sensor_pose).translation());
  }
  pair.truth = Pose2(5.5, 4.5, 0.6).to_isometry();
  const auto s = pair.scanner.scan(pair.world, pair.truth, 20.0, 1, rng);
  pair.scan = s.cloud;
  const double c = std::cos(0.7), sn = std::sin(0.7);
  pair.initial = pair.truth * Pose2(translation_error * c, translation_error * sn, yaw_error_deg * M_PI / 180).to_isometry();
  return pair;
}

inline double translation_error(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}
inline double rotation_error_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

}  // namespace locd::bench
