// The exploration benchmark's yardsticks on the toy world: the coverage denominator (the
// observable static surface, computed once per world) and the nearest-frontier baseline.
#include <gtest/gtest.h>

#include <cmath>

#include "locd/icp_explorer/layered_hexahedral_map.hpp"
#include "locd/icp_explorer/next_best_view.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sim_icp_explorer/surface_coverage.hpp"
#include "locd/icp_explorer/nearest_frontier.hpp"
#include "toy_world.hpp"

namespace ie = locd::icp_explorer;
using locd::Pose2;
using locd::sim::SurfaceCoverage;

namespace {

locd::sim::Scanner3DConfig noiseless(locd::sim::Scanner3DConfig c) {
  c.range_stddev = 0.0;
  c.intensity_stddev = 0.0;
  return c;
}

// Reference from every free, reachable metre of the two rooms (a 0.5 m grid, every other point),
// from z 0.05 m up to 2.3 m (the ceiling is at 2.4 m).
SurfaceCoverage toy_coverage(const locd::sim::IndoorWorld& world) {
  return SurfaceCoverage(world, noiseless(locd::test::coarse_scanner()), 0.2, 0.5, 0.3, {3.0, 1.2}, 2, 0.05, 2.3);
}

}  // namespace

TEST(SurfaceCoverage, ReferenceIsTheSurfaceSeenFromReachablePositionsOnly) {
  const auto world = locd::test::two_rooms();
  const SurfaceCoverage coverage = toy_coverage(world);
  ASSERT_GT(coverage.reference_voxels(), 100u);
  // Reachable positions: both rooms through the door, none inside walls or furniture.
  bool room_b = false;
  for (const auto& xy : coverage.reachable_positions()) {
    EXPECT_TRUE(world.footprint_free(xy, 0.3, 0.05, 0.9)) << xy.transpose();
    room_b |= xy.x() > 6.2;
  }
  EXPECT_TRUE(room_b);
  // The west wall's face lies on a voxel boundary (x = 0): the voxel in front of it counts, the
  // one inside the wall does not.
  EXPECT_TRUE(coverage.in_reference(Eigen::Vector3f(0.1f, 2.1f, 1.1f)));
  EXPECT_FALSE(coverage.in_reference(Eigen::Vector3f(-0.1f, 2.1f, 1.1f)));
  // The crate's top (1.1 m) is above the scanner (0.8 m): no position sees it.
  EXPECT_FALSE(coverage.in_reference(Eigen::Vector3f(4.9f, 0.5f, 1.1f)));
  // Floor and ceiling slabs are not counted.
  EXPECT_FALSE(coverage.in_reference(Eigen::Vector3f(3.1f, 2.1f, 0.01f)));
  EXPECT_FALSE(coverage.in_reference(Eigen::Vector3f(3.1f, 2.1f, 2.39f)));
}

TEST(SurfaceCoverage, ScansFromTheReferencePositionsCoverItAllAndOneScanPartOfIt) {
  const auto world = locd::test::two_rooms();
  SurfaceCoverage coverage = toy_coverage(world);
  const locd::sim::Scanner3D scanner(locd::test::coarse_scanner());
  std::mt19937_64 rng(3);
  coverage.add(scanner.scan(world, Pose2(3.0, 1.2, 0.0).to_isometry(), 0.0, 0, rng), world);
  const double one = coverage.ratio();
  EXPECT_GT(one, 0.2);
  EXPECT_LT(one, 0.8) << "room B is mostly hidden from room A";
  // The reference was made from every other grid point; scanning from all of them (noise-free
  // hit points are what coverage counts) covers every reference voxel.
  const auto& all = coverage.reachable_positions();
  for (size_t i = 0; i < all.size(); ++i) coverage.add(scanner.scan(world, Pose2(all[i].x(), all[i].y(), 0.3 * i).to_isometry(), 0.0, 0, rng), world);
  EXPECT_DOUBLE_EQ(coverage.ratio(), 1.0);
  EXPECT_EQ(coverage.covered_voxels(), coverage.reference_voxels());
}

TEST(SurfaceCoverage, PeopleCountForNeitherTheReferenceNorTheCoverage) {
  const auto empty = locd::test::two_rooms();
  std::vector<locd::sim::WalkingPerson> people(1);
  people[0].from = {2.0, 2.0};
  people[0].to = {2.0, 2.0};  // standing next to the robot, hiding part of the room
  const locd::sim::IndoorWorld crowded(empty.boxes(), people);
  SurfaceCoverage with_people = toy_coverage(crowded);
  EXPECT_EQ(with_people.reference_voxels(), toy_coverage(empty).reference_voxels());
  const locd::sim::Scanner3D scanner(locd::test::coarse_scanner());
  std::mt19937_64 rng(4);
  SurfaceCoverage without_people = toy_coverage(empty);
  with_people.add(scanner.scan(crowded, Pose2(3.0, 1.2, 0.0).to_isometry(), 0.0, 0, rng), crowded);
  without_people.add(scanner.scan(empty, Pose2(3.0, 1.2, 0.0).to_isometry(), 0.0, 0, rng), empty);
  EXPECT_GT(with_people.covered_voxels(), 0u);
  EXPECT_LT(with_people.covered_voxels(), without_people.covered_voxels()) << "the person hides, never adds";
}

namespace {

ie::LayeredMapSettings toy_map_settings(const locd::sim::Scanner3D& scanner) {
  ie::LayeredMapSettings s;
  s.origin = {-0.5, -0.5};
  s.size = {11.0, 5.0};
  s.z_max = 2.3;
  s.azimuth_step = scanner.azimuth_step();
  s.elevation_step = scanner.elevation_step();
  return s;
}

void scan_into(ie::LayeredHexahedralMap& map, const locd::sim::IndoorWorld& world, const locd::sim::Scanner3D& scanner,
               const Pose2& pose, uint64_t seed) {
  const auto points = locd::test::scan_in_map(world, scanner, pose.to_isometry(), 0.1, seed);
  map.integrate(points.points, (pose.to_isometry() * scanner.sensor_in_base()).translation());
}

size_t at(const ie::LayeredHexahedralMap& map, const Eigen::Vector2d& xy) {
  int c = 0, r = 0;
  EXPECT_TRUE(map.column_of(xy, c, r));
  return static_cast<size_t>(r) * map.columns() + c;
}

}  // namespace

TEST(Traversability, ObstacleExtentIsTheReturnsNotTheCube) {
  const auto world = locd::test::two_rooms();
  const locd::sim::Scanner3D scanner(locd::test::coarse_scanner());
  ie::LayeredHexahedralMap map(toy_map_settings(scanner));
  scan_into(map, world, scanner, Pose2(3.0, 1.2, 0.0), 5);
  // The door's south jamb face (y = 1.5) lies on a cube boundary; its column's obstacle is the
  // 0.2 m-thick jamb (x 6..6.2), a strip at the face, not the 0.25 m cube.
  int c = 0, r = 0;
  ASSERT_TRUE(map.column_of({6.1, 1.45}, c, r));
  ASSERT_EQ(map.column_state(c, r, 1.2), ie::CellState::kOccupied);
  const Eigen::AlignedBox2d box = map.obstacle_extent(c, r, 1.2);
  EXPECT_GE(box.min().x(), 6.0 - 0.02);
  EXPECT_LE(box.max().x(), 6.2 + 0.02);
  EXPECT_GE(box.max().y(), 1.4);
  EXPECT_LE(box.max().y(), 1.5 + 0.02);
  ASSERT_TRUE(map.column_of({3.0, 2.0}, c, r));
  EXPECT_TRUE(map.obstacle_extent(c, r, 1.2).isEmpty()) << "open floor";
}

TEST(Traversability, AOneMetreDoorOnCubeBoundariesIsPassableAHalfMetreOneIsNot) {
  const locd::sim::Scanner3D scanner(locd::test::coarse_scanner());
  ie::ExplorationSettings settings;
  settings.robot_radius = 0.3;
  const ie::NextBestViewPlanner planner(settings);
  // The toy door (y 1.5..2.5, both jambs on cube boundaries), seen from both rooms.
  const auto world = locd::test::two_rooms();
  ie::LayeredHexahedralMap map(toy_map_settings(scanner));
  scan_into(map, world, scanner, Pose2(4.5, 2.0, 0.0), 6);
  scan_into(map, world, scanner, Pose2(7.7, 2.0, 0.0), 7);
  const auto m = planner.movable(map, {4.5, 2.0});
  EXPECT_EQ(m[at(map, {8.5, 2.0})], 1.0f) << "room B reachable through the 1 m door";
  // The same rooms with a 0.5 m door: a 0.6 m wide robot cannot pass.
  std::vector<locd::sim::SurfaceBox> boxes;
  for (const auto& b : world.boxes()) {
    if (b.label == "wall" && b.box.min().x() == 6.0 && b.box.max().y() == 1.5)
      boxes.push_back({Eigen::AlignedBox3d(Eigen::Vector3d(6.0, 0.0, 0.0), Eigen::Vector3d(6.2, 1.75, 2.4)), b.reflectivity, "wall"});
    else if (b.label == "wall" && b.box.min().x() == 6.0 && b.box.min().y() == 2.5)
      boxes.push_back({Eigen::AlignedBox3d(Eigen::Vector3d(6.0, 2.25, 0.0), Eigen::Vector3d(6.2, 4.0, 2.4)), b.reflectivity, "wall"});
    else
      boxes.push_back(b);
  }
  const locd::sim::IndoorWorld narrow(boxes, {});
  ie::LayeredHexahedralMap narrow_map(toy_map_settings(scanner));
  scan_into(narrow_map, narrow, scanner, Pose2(4.5, 2.0, 0.0), 6);
  scan_into(narrow_map, narrow, scanner, Pose2(7.7, 2.0, 0.0), 7);
  const auto blocked = planner.movable(narrow_map, {4.5, 2.0});
  EXPECT_EQ(blocked[at(narrow_map, {8.5, 2.0})], 0.0f);
  EXPECT_EQ(blocked[at(narrow_map, {4.0, 2.0})], 1.0f) << "room A itself stays movable";
}

TEST(NearestFrontier, GoesToTheNearestUnresolvedFrontierAndStopsWhenNoneIsLeft) {
  const auto world = locd::test::two_rooms();
  const locd::sim::Scanner3D scanner(locd::test::coarse_scanner());
  ie::LayeredHexahedralMap map(toy_map_settings(scanner));
  ie::ExplorationSettings settings;
  settings.max_range = 15.0;
  const ie::NextBestViewPlanner planner(settings);
  std::vector<Eigen::Vector2d> stops = {{3.0, 1.2}};
  scan_into(map, world, scanner, Pose2(3.0, 1.2, 0.0), 5);
  const auto goal = locd::icp_explorer::nearest_frontier(map, planner, stops.back(), stops, 1.0);
  ASSERT_TRUE(goal.has_value());
  // A reachable, known-empty scan position at least 1 m from the robot, next to a frontier
  // (an empty column with an unknown neighbour).
  EXPECT_EQ(planner.movable(map, stops.back())[at(map, *goal)], 1.0f);
  EXPECT_GE((*goal - stops.back()).norm(), 1.0 - 1e-9);
  bool next_to_frontier = false;
  for (double dy = -0.75; dy <= 0.75; dy += 0.25)
    for (double dx = -0.75; dx <= 0.75; dx += 0.25) {
      int c = 0, r = 0;
      if (!map.column_of(*goal + Eigen::Vector2d(dx, dy), c, r)) continue;
      if (map.column_state(c, r, settings.robot_height) != ie::CellState::kEmpty) continue;
      for (const Eigen::Vector2d& n : {Eigen::Vector2d(0.25, 0), Eigen::Vector2d(-0.25, 0), Eigen::Vector2d(0, 0.25), Eigen::Vector2d(0, -0.25)}) {
        int cn = 0, rn = 0;
        if (map.column_of(*goal + Eigen::Vector2d(dx, dy) + n, cn, rn) &&
            map.column_state(cn, rn, settings.robot_height) == ie::CellState::kUnknown)
          next_to_frontier = true;
      }
    }
  EXPECT_TRUE(next_to_frontier);
  // Following its goals it keeps going until no frontier is left, and gets there.
  std::optional<Eigen::Vector2d> next = goal;
  int scans = 1;
  while (next && scans < 30) {
    stops.push_back(*next);
    scan_into(map, world, scanner, Pose2(next->x(), next->y(), 0.0), 10 + scans);
    ++scans;
    next = locd::icp_explorer::nearest_frontier(map, planner, stops.back(), stops, 1.0);
  }
  EXPECT_FALSE(next.has_value()) << "no frontier left after " << scans << " scans";
  bool visited_room_b = false;
  for (const auto& s : stops) visited_room_b |= s.x() > 6.2;
  EXPECT_TRUE(visited_room_b);
}
