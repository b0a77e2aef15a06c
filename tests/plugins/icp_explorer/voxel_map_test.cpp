// The voxel model: the two-nearest search against brute force, and free-space carving of
// moving objects' ghosts (removed when later scans see through them; real surfaces stay).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "locd/icp_explorer/voxel_map.hpp"

namespace ie = locd::icp_explorer;

namespace {

// Points on the plane x = x0 (y in [y0, y1], z in [0, 2]) every `step` metres.
ie::ScanPoints wall_x(double x0, double y0, double y1, double step = 0.05) {
  ie::ScanPoints s;
  for (double y = y0; y <= y1 + 1e-9; y += step)
    for (double z = 0.0; z <= 2.0 + 1e-9; z += step) s.points.emplace_back(x0, y, z);
  return s;
}

// Points on the plane y = y0 (x in [x0, x1], z in [0, 2]).
ie::ScanPoints wall_y(double y0, double x0, double x1, double step = 0.05) {
  ie::ScanPoints s;
  for (double x = x0; x <= x1 + 1e-9; x += step)
    for (double z = 0.0; z <= 2.0 + 1e-9; z += step) s.points.emplace_back(x, y0, z);
  return s;
}

ie::ScanPoints join(ie::ScanPoints a, const ie::ScanPoints& b) {
  a.points.insert(a.points.end(), b.points.begin(), b.points.end());
  return a;
}

size_t voxels_near(const ie::VoxelMap& map, const Eigen::AlignedBox3d& box) {
  size_t n = 0;
  for (const auto& p : map.points()) n += box.contains(p);
  return n;
}

}  // namespace

TEST(VoxelMap, NearestTwoMatchBruteForceWithinTheBound) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  ie::ScanPoints cloud;
  for (int i = 0; i < 3000; ++i) cloud.points.emplace_back(u(rng), u(rng), 0.3 * u(rng));
  ie::VoxelMap map(0.1);
  map.insert(cloud, Eigen::Vector3d(0, 0, 5));
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d x(u(rng), u(rng), u(rng));
    std::vector<double> d2;
    for (const auto& p : map.points()) d2.push_back((p - x).squaredNorm());
    std::vector<double> sorted = d2;
    std::sort(sorted.begin(), sorted.end());
    for (double bound2 : {1e9, 0.04, sorted[1] * 1.01, sorted[0] * 0.5}) {
      size_t index[2];
      double distance2[2];
      const size_t found = map.nearest_two_within(x, bound2, index, distance2);
      const size_t expected = (sorted[0] < bound2) + (sorted[1] < bound2);
      ASSERT_EQ(found, expected) << "bound2 " << bound2;
      if (found > 0) EXPECT_NEAR(distance2[0], sorted[0], 1e-9);
      if (found > 1) {
        EXPECT_LE(distance2[1], sorted[1] + 1e-9);
        EXPECT_GE(std::sqrt(distance2[1]), std::sqrt(sorted[1]) - 2e-5) << "a lower bound, within float rounding";
      } else {
        EXPECT_DOUBLE_EQ(distance2[1], bound2) << "the bound stands in for a second one not found";
      }
    }
  }
}

TEST(VoxelMapCarving, AGhostSeenOnceIsRemovedWhenALaterScanSeesThroughIt) {
  const Eigen::Vector3d scanner(0.0, 0.0, 1.0);
  // Scan 1: the wall at x = 5 and a person-like patch at x = 2.5 in front of it.
  const ie::ScanPoints person = wall_x(2.5, -0.25, 0.25);
  ie::VoxelMap map(0.1);
  map.insert(join(wall_x(5.0, -2.0, 2.0), person), scanner);
  const Eigen::AlignedBox3d ghost_region(Eigen::Vector3d(2.3, -0.4, -0.1), Eigen::Vector3d(2.7, 0.4, 2.1));
  const size_t ghost = voxels_near(map, ghost_region);
  ASSERT_GT(ghost, 50u);
  const size_t before = map.size();
  // Scan 2 from a nearby spot: the person has gone, the rays reach the wall through where it
  // stood. Rays from z = 1 to the wall's z in [0, 2] cross x = 2.5 at z in [0.53, 1.47]: that
  // band of the ghost is seen through, the rest is not.
  const Eigen::Vector3d scanner2(0.3, 0.2, 1.0);
  const ie::ScanPoints wall = wall_x(5.0, -2.0, 2.0);
  const Eigen::AlignedBox3d seen_through(Eigen::Vector3d(2.3, -0.4, 0.6), Eigen::Vector3d(2.7, 0.4, 1.4));
  const size_t band = voxels_near(map, seen_through);
  ASSERT_GT(band, 20u);
  const size_t carved = map.carve(wall.points, scanner2);
  EXPECT_EQ(voxels_near(map, seen_through), 0u) << "the band the rays pass through is gone";
  EXPECT_GE(carved, band);
  EXPECT_GT(voxels_near(map, ghost_region), 0u) << "the parts no ray passed through stay";
  EXPECT_EQ(map.size(), before - carved);
  EXPECT_EQ(voxels_near(map, Eigen::AlignedBox3d(Eigen::Vector3d(4.8, -2.1, -0.1), Eigen::Vector3d(5.2, 2.1, 2.1))),
            before - ghost)
      << "the wall the rays end on stays whole";
  EXPECT_EQ(map.scans_seen(0), 1);
  // The map stays consistent: nearest neighbours come from the kept voxels.
  size_t index = 0;
  double distance2 = 0.0;
  ASSERT_TRUE(map.nearest(Eigen::Vector3d(2.5, 0.0, 1.0), index, distance2));
  EXPECT_GT(distance2, 0.3 * 0.3);
}

TEST(VoxelMapCarving, SurfacesSeenTwiceOrOnlyGrazedOrAtTheRayEndStay) {
  const Eigen::Vector3d scanner(0.0, 0.0, 1.0);
  ie::VoxelMap twice(0.1);
  const ie::ScanPoints person = wall_x(2.5, -0.25, 0.25);
  twice.insert(join(wall_x(5.0, -2.0, 2.0), person), scanner);
  twice.insert(person, scanner);  // a second scan saw it too: not a passer-by
  EXPECT_EQ(twice.carve(wall_x(5.0, -2.0, 2.0).points, Eigen::Vector3d(0.3, 0.2, 1.0)), 0u);
  // A side wall (y = 1) seen once; the next scan's rays run along it, 3 cm off its face, to a far
  // wall: they graze its voxels, they do not see through them.
  ie::VoxelMap grazed(0.1);
  grazed.insert(join(wall_y(1.0, 0.0, 4.0), wall_x(6.0, -1.0, 1.0)), Eigen::Vector3d(2.0, 0.0, 1.0));
  std::vector<Eigen::Vector3d> along;
  for (double z = 0.0; z <= 2.0; z += 0.05) along.emplace_back(6.0, 1.03, z);
  EXPECT_EQ(grazed.carve(along, Eigen::Vector3d(-1.0, 1.03, 1.0)), 0u);
  // A floor seen once; the next scan's rays reach the floor farther on at 18 degrees: they
  // cross the floor's own voxels (0.32 m of ray in the 0.1 m slab, more than end_margin) just
  // before their ends, which is not seeing through them.
  ie::VoxelMap floor(0.1);
  ie::ScanPoints floor_points;
  for (double x = 0.0; x <= 6.0; x += 0.05)
    for (double y = -1.0; y <= 1.0; y += 0.05) floor_points.points.emplace_back(x, y, 0.0);
  floor.insert(floor_points, Eigen::Vector3d(3.0, 0.0, 0.8));
  std::vector<Eigen::Vector3d> shallow;
  const double run = 0.8 / std::tan(18.0 * M_PI / 180.0);  // 2.46 m
  for (double y = -0.9; y <= 0.9; y += 0.05)
    for (double x : {0.0, 0.02, 0.04, 0.06, 0.08}) shallow.emplace_back(run + 0.5 + x, y, 0.0);
  EXPECT_EQ(floor.carve(shallow, Eigen::Vector3d(0.5, 0.0, 0.8)), 0u);
  // An object's edge in the middle of a voxel (a panel x = 2.5, y up to 0.22, seen once): rays
  // passing just beside the edge cross that voxel, but cross the panel's plane off the panel.
  ie::VoxelMap edge(0.1);
  edge.insert(join(wall_x(2.5, -0.5, 0.22, 0.02), wall_x(5.0, -2.0, 2.0)), scanner);
  std::vector<Eigen::Vector3d> beside;
  for (double y = 0.25; y <= 0.29; y += 0.01)
    for (double z = 0.8; z <= 1.2; z += 0.02) beside.emplace_back(5.0, y, z);
  EXPECT_EQ(edge.carve(beside, Eigen::Vector3d(0.0, 0.27, 1.0)), 0u);
  // Rays that end on a once-seen surface do not carve it (end_margin).
  ie::VoxelMap ends(0.1);
  ends.insert(wall_x(5.0, -2.0, 2.0), scanner);
  EXPECT_EQ(ends.carve(wall_x(5.0, -2.0, 2.0).points, Eigen::Vector3d(0.5, -0.3, 1.0)), 0u);
}
