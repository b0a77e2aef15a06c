// Small worlds and scans for icp_explorer's tests: two rooms joined by a door, a table whose
// top hides the floor below it, and a coarse scanner (about 20k rays) so every test stays fast.
#pragma once

#include <random>

#include "locd/icp_explorer/scan_points.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sim_icp_explorer/indoor_world.hpp"
#include "locd/sim_icp_explorer/scanner3d.hpp"

namespace locd::test {

// Room A: x in [0, 6], y in [0, 4]; room B: x in [6.2, 10], y in [0, 4]; a 1 m door in the wall
// x = 6..6.2 at y in [1.5, 2.5]; height 2.4 m; a table in room A at x 1..2.2, y 2.6..3.4.
inline sim::IndoorWorld two_rooms() {
  std::vector<sim::SurfaceBox> b;
  auto add = [&](Eigen::Vector3d lo, Eigen::Vector3d hi, float r, const char* label) {
    b.push_back({Eigen::AlignedBox3d(lo, hi), r, label});
  };
  add({0, 0, -0.2}, {10, 4, 0}, 0.3f, "floor");
  add({0, 0, 2.4}, {10, 4, 2.6}, 0.8f, "ceiling");
  add({-0.2, -0.2, 0}, {10.2, 0, 2.4}, 0.6f, "wall");
  add({-0.2, 4, 0}, {10.2, 4.2, 2.4}, 0.6f, "wall");
  add({-0.2, 0, 0}, {0, 4, 2.4}, 0.6f, "wall");
  add({10, 0, 0}, {10.2, 4, 2.4}, 0.6f, "wall");
  add({6, 0, 0}, {6.2, 1.5, 2.4}, 0.5f, "wall");
  add({6, 2.5, 0}, {6.2, 4, 2.4}, 0.5f, "wall");
  add({6, 1.5, 2.0}, {6.2, 2.5, 2.4}, 0.5f, "lintel");
  add({1.0, 2.6, 0.7}, {2.2, 3.4, 0.75}, 0.35f, "table");
  add({4.5, 0.3, 0}, {5.3, 0.9, 1.1}, 0.9f, "crate");
  add({8.0, 3.0, 0}, {9.5, 3.8, 0.9}, 0.15f, "cabinet");
  return sim::IndoorWorld(std::move(b), {});
}

inline sim::Scanner3DConfig coarse_scanner() {
  sim::Scanner3DConfig c;
  c.azimuth_steps = 360;
  c.elevation_steps = 60;
  c.max_range = 15.0;
  return c;
}

inline icp_explorer::ScanPoints scan_in_map(const sim::IndoorWorld& world, const sim::Scanner3D& scanner,
                                            const Eigen::Isometry3d& pose, double voxel, uint64_t seed) {
  std::mt19937_64 rng(seed);
  const auto s = scanner.scan(world, pose, 0.0, 0, rng);
  return icp_explorer::voxel_downsample(s.cloud.points, s.cloud.intensity, voxel, pose * s.cloud.sensor_pose);
}

}  // namespace locd::test
