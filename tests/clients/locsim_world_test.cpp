#include <gtest/gtest.h>

#include <random>

#include "locd/sdk/feature_map.hpp"
#include "locd/sim/grid_world.hpp"
#include "locd/sim/world_differences.hpp"
#include "locd/sim/world.hpp"
#include "locsim_paths.hpp"

using locd::OccupancyMap;
using locd::sim::GridWorld;
using locd::sim::Segment;
using locd::sim::SegmentWorld;

TEST(RaySegment, ExactDistanceAndMisses) {
  const Eigen::Vector2d origin(0, 0), east(1, 0);
  const Segment wall{{2, -1}, {2, 1}};
  ASSERT_TRUE(locd::sim::ray_segment_distance(origin, east, wall));
  EXPECT_DOUBLE_EQ(*locd::sim::ray_segment_distance(origin, east, wall), 2.0);
  EXPECT_FALSE(locd::sim::ray_segment_distance(origin, Eigen::Vector2d(-1, 0), wall));  // behind
  EXPECT_FALSE(locd::sim::ray_segment_distance(origin, Eigen::Vector2d(0, 1), wall));   // parallel
  EXPECT_FALSE(locd::sim::ray_segment_distance(origin, east, Segment{{2, 0.5}, {2, 1}}));  // passes below
  const Eigen::Vector2d diagonal = Eigen::Vector2d(1, 1).normalized();
  EXPECT_FALSE(locd::sim::ray_segment_distance(origin, diagonal, wall));  // passes above its end (2, 1)
  EXPECT_NEAR(*locd::sim::ray_segment_distance(origin, diagonal, Segment{{2, -1}, {2, 3}}), 2.0 * std::sqrt(2.0), 1e-12);
}

TEST(SegmentWorld, CastsInsideABoxGiveExactRanges) {
  // A 4 x 2 m room.
  const SegmentWorld world({{{0, 0}, {4, 0}}, {{4, 0}, {4, 2}}, {{4, 2}, {0, 2}}, {{0, 2}, {0, 0}}}, 0.5);
  const Eigen::Vector2d o(1, 1);
  EXPECT_NEAR(*world.cast(o, 0.0, 10), 3.0, 1e-12);
  EXPECT_NEAR(*world.cast(o, M_PI / 2, 10), 1.0, 1e-12);
  EXPECT_NEAR(*world.cast(o, M_PI, 10), 1.0, 1e-12);
  EXPECT_NEAR(*world.cast(o, -M_PI / 2, 10), 1.0, 1e-12);
  EXPECT_NEAR(*world.cast(o, M_PI / 4, 10), std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(*world.cast(o, std::atan2(-1.0, 3.0), 10), std::sqrt(10.0), 1e-12);  // into the corner (4, 0)
  EXPECT_FALSE(world.cast(o, 0.0, 2.5));  // wall at 3 m is beyond max range
}

TEST(SegmentWorld, GridTraversalMatchesBruteForceOnTheCorridor) {
  const auto map = locd::load_feature_map(locd::sim::test::source_dir() + "/config/maps/corridor.yaml", 100000);
  const SegmentWorld world = SegmentWorld::from_feature_map(map);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> x(-2, 42), y(-2, 22), angle(-M_PI, M_PI);
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector2d o(x(rng), y(rng));
    const double a = angle(rng);
    const auto fast = world.cast(o, a, 30.0);
    const auto direct = world.cast_brute_force(o, a, 30.0);
    ASSERT_EQ(fast.has_value(), direct.has_value()) << "origin " << o.transpose() << " angle " << a;
    if (fast) {
      ++hits;
      ASSERT_NEAR(*fast, *direct, 1e-9) << "origin " << o.transpose() << " angle " << a;
    }
  }
  EXPECT_GT(hits, 15000);
}

TEST(SegmentWorld, CorridorIsClosed) {
  // From anywhere on the corridor's centre line every direction hits a wall within 45 m.
  const auto map = locd::load_feature_map(locd::sim::test::source_dir() + "/config/maps/corridor.yaml", 100000);
  const SegmentWorld world = SegmentWorld::from_feature_map(map);
  for (double x = 1; x <= 39; x += 0.7) {
    for (double a = -M_PI; a < M_PI; a += 0.01) {
      ASSERT_TRUE(world.cast({x, 1.0}, a, 45.0)) << x << " " << a;
      ASSERT_TRUE(world.cast({x, 19.0}, a, 45.0)) << x << " " << a;
    }
  }
}

namespace {

// A width x height grid at `resolution` from `origin`, free but for the (row, col) cells given.
struct TestGrid {
  locd::GridGeometry geometry;
  std::vector<int8_t> cells;
  TestGrid(int width, int height, double resolution, Eigen::Vector2d origin = Eigen::Vector2d::Zero()) {
    geometry.width = width;
    geometry.height = height;
    geometry.resolution = resolution;
    geometry.origin = origin;
    cells.assign(geometry.size(), OccupancyMap::kFree);
  }
  TestGrid& set(int row, int col, int8_t value = OccupancyMap::kOccupied) {
    cells[static_cast<size_t>(row) * geometry.width + col] = value;
    return *this;
  }
  GridWorld world() const { return GridWorld(std::make_shared<OccupancyMap>(geometry, cells)); }
};

constexpr double kExact = 1e-9;  // m

}  // namespace

TEST(GridWorld, AxisAlignedWallIsHitAtItsFace) {
  // 0.1 m cells; column 10 (x in [1.0, 1.1]) is a wall.
  TestGrid grid(30, 20, 0.1);
  for (int r = 0; r < 20; ++r) grid.set(r, 10);
  const GridWorld world = grid.world();
  EXPECT_NEAR(*world.cast({0.55, 0.55}, 0.0, 10.0), 0.45, kExact);          // west face
  EXPECT_NEAR(*world.cast({2.55, 1.23}, M_PI, 10.0), 1.45, kExact);         // east face
  EXPECT_NEAR(*world.cast({0.55, 0.25}, M_PI / 4, 10.0), 0.45 * std::sqrt(2.0), kExact);  // diagonal beam
  EXPECT_FALSE(world.cast({0.55, 0.55}, M_PI, 10.0));       // away from it: leaves the map
  EXPECT_FALSE(world.cast({0.55, 0.55}, M_PI / 2, 10.0));   // parallel to it
  EXPECT_FALSE(world.cast({0.55, 0.55}, 0.0, 0.44));        // beyond max range
  EXPECT_NEAR(*world.cast({0.55, 0.55}, 0.0, 0.45 + 1e-9), 0.45, kExact);  // at max range
  EXPECT_DOUBLE_EQ(*world.cast({1.05, 0.55}, 0.0, 10.0), 0.0);  // from inside a solid cell
}

TEST(GridWorld, DiagonalWallAndItsCorners) {
  // A staircase wall: cells (i, i) of 0.05 m, from a grid origin off zero.
  const Eigen::Vector2d o(-1.3, 0.7);
  TestGrid grid(40, 40, 0.05, o);
  for (int i = 0; i < 40; ++i) grid.set(i, i);
  const GridWorld world = grid.world();
  // Along row 5 (y in [0.25, 0.3] from the origin) from its west end: the cell (5, 5) at x = 0.25.
  EXPECT_NEAR(*world.cast(o + Eigen::Vector2d(0.01, 0.27), 0.0, 10.0), 0.24, kExact);
  // Parallel to the staircase, 0.15 m to its south-east: it never touches the wall.
  EXPECT_FALSE(world.cast(o + Eigen::Vector2d(0.175, 0.025), M_PI / 4, 10.0));
  // Parallel to it along the line through its cells' south-east corners: stops at the first corner
  // ahead, (0.15, 0.10) for a beam from (0.125, 0.075) (no gap between diagonal cells).
  EXPECT_NEAR(*world.cast(o + Eigen::Vector2d(0.125, 0.075), M_PI / 4, 10.0), 0.025 * std::sqrt(2.0), kExact);
  // Perpendicular to it from the south-east, on x + y = 0.95: meets the staircase inside cell
  // (9, 9) and first touches that cell's south-east corner (0.5, 0.45).
  EXPECT_NEAR(*world.cast(o + Eigen::Vector2d(0.6, 0.35), 3 * M_PI / 4, 10.0), 0.1 * std::sqrt(2.0), kExact);
}

TEST(GridWorld, BeamAlongAGridLineTouchesTheCellsOnBothSides) {
  // Row 4 (y in [0.4, 0.5]) solid in columns 10..12 (x in [1.0, 1.3]), column 20 solid in rows 2..3.
  TestGrid grid(30, 10, 0.1);
  for (int c = 10; c <= 12; ++c) grid.set(4, c);
  grid.set(2, 20).set(3, 20);
  const GridWorld world = grid.world();
  EXPECT_NEAR(*world.cast({0.05, 0.5}, 0.0, 10.0), 0.95, kExact);   // along its top face
  EXPECT_NEAR(*world.cast({0.05, 0.4}, 0.0, 10.0), 0.95, kExact);   // along its bottom face
  EXPECT_NEAR(*world.cast({2.55, 0.5}, M_PI, 10.0), 1.25, kExact);  // from the east
  EXPECT_FALSE(world.cast({0.05, 0.6}, 0.0, 1.9));                  // one row above: clear
  EXPECT_NEAR(*world.cast({2.0, 0.05}, M_PI / 2, 10.0), 0.15, kExact);  // along column 20's west face
  EXPECT_NEAR(*world.cast({2.1, 0.95}, -M_PI / 2, 10.0), 0.55, kExact);  // along its east face, downwards
  EXPECT_FALSE(world.cast({2.2, 0.05}, M_PI / 2, 10.0));  // a column further east: clear to the map's edge
}

TEST(GridWorld, CellEdgesAndCorners) {
  // One solid cell, (5, 5): [0.5, 0.6] x [0.5, 0.6].
  TestGrid grid(20, 20, 0.1);
  grid.set(5, 5);
  const GridWorld world = grid.world();
  const Eigen::Vector2d from(0.05, 0.05);
  EXPECT_NEAR(*world.cast({0.05, 0.55}, 0.0, 10.0), 0.45, kExact);  // middle of its west edge
  EXPECT_NEAR(*world.cast(from, M_PI / 4, 10.0), 0.45 * std::sqrt(2.0), kExact);  // its south-west corner
  // Aimed a little below that corner: passes under it, then enters through the south edge at x = 0.51.
  EXPECT_NEAR(*world.cast(from, std::atan2(0.45, 0.46), 10.0), std::hypot(0.46, 0.45), kExact);
  // Through its south-east corner (0.6, 0.5) from below-left: touches only that corner.
  EXPECT_NEAR(*world.cast(from, std::atan2(0.45, 0.55), 10.0), std::hypot(0.55, 0.45), kExact);
  // A hair further clockwise: misses it.
  EXPECT_FALSE(world.cast(from, std::atan2(0.449, 0.55), 10.0));
  // Its north-west corner from the north-west, and its north edge from straight above.
  EXPECT_NEAR(*world.cast({0.3, 0.8}, -M_PI / 4, 10.0), 0.2 * std::sqrt(2.0), kExact);
  EXPECT_NEAR(*world.cast({0.57, 1.55}, -M_PI / 2, 10.0), 0.95, kExact);
}

TEST(GridWorld, OffTheMap) {
  // A 2 x 2 m map at 0.1 m from (0, 0) with column 10 solid.
  TestGrid grid(20, 20, 0.1);
  for (int r = 0; r < 20; ++r) grid.set(r, 10);
  const GridWorld world = grid.world();
  EXPECT_NEAR(*world.cast({-1.0, 0.55}, 0.0, 10.0), 2.0, kExact);      // enters the map from the west
  EXPECT_NEAR(*world.cast({-1.0, -1.0}, M_PI / 4, 10.0), 2.0 * std::sqrt(2.0), kExact);  // through its corner
  EXPECT_FALSE(world.cast({-1.0, 0.55}, M_PI, 10.0));   // away from it
  EXPECT_FALSE(world.cast({-1.0, -0.5}, 0.0, 10.0));    // passes south of it
  EXPECT_FALSE(world.cast({-1.0, 0.55}, 0.0, 1.9));     // the wall is beyond max range
  EXPECT_FALSE(world.cast({0.5, 0.5}, M_PI, 10.0));     // leaves the map: nothing outside it
  EXPECT_NEAR(*world.cast({3.0, 0.55}, M_PI, 10.0), 1.9, kExact);  // from the east, off the map
}

TEST(GridWorld, GreyFromFiftyIsSolidUnknownIsNot) {
  TestGrid grid(20, 3, 0.1);
  grid.set(1, 5, 49).set(1, 8, -1).set(1, 12, 50).set(0, 3, 99).set(2, 3, 1);
  const GridWorld world = grid.world();
  EXPECT_NEAR(*world.cast({0.05, 0.15}, 0.0, 10.0), 1.15, kExact);  // through 49 and unknown, stops at 50
  EXPECT_NEAR(*world.cast({0.05, 0.05}, 0.0, 10.0), 0.25, kExact);  // 99 stops
  EXPECT_FALSE(world.cast({0.05, 0.25}, 0.0, 10.0));                 // 1 does not
}

TEST(GridWorld, MatchesTheSegmentOutlinesOfItsSolidCells) {
  // Every solid cell as its four edges in a SegmentWorld (exact ray-segment intersections): both
  // worlds must give the same range for random beams from random places, off the map included.
  const Eigen::Vector2d o(-1.3, 0.7);
  const double res = 0.05;
  TestGrid grid(60, 50, res, o);
  std::mt19937_64 rng(11);
  std::bernoulli_distribution solid(0.08);
  std::vector<Segment> edges;
  for (int r = 0; r < 50; ++r) {
    for (int c = 0; c < 60; ++c) {
      if (!solid(rng)) continue;
      grid.set(r, c);
      const Eigen::Vector2d a = o + Eigen::Vector2d(c, r) * res, b = a + Eigen::Vector2d(res, 0),
                            d = a + Eigen::Vector2d(0, res), e = a + Eigen::Vector2d(res, res);
      edges.push_back({a, b});
      edges.push_back({b, e});
      edges.push_back({e, d});
      edges.push_back({d, a});
    }
  }
  const GridWorld world = grid.world();
  const SegmentWorld outlines(edges, 0.5);
  std::uniform_real_distribution<double> x(o.x() - 0.5, o.x() + 3.5), y(o.y() - 0.5, o.y() + 3.0),
      angle(-M_PI, M_PI);
  int hits = 0, compared = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector2d p(x(rng), y(rng));
    int row = 0, col = 0;
    if (grid.geometry.index_of(p, row, col) && grid.cells[static_cast<size_t>(row) * 60 + col] != 0) continue;
    const double a = angle(rng);
    const auto got = world.cast(p, a, 2.0);
    const auto want = outlines.cast_brute_force(p, a, 2.0);
    ++compared;
    ASSERT_EQ(got.has_value(), want.has_value()) << "origin " << p.transpose() << " angle " << a;
    if (got) {
      ++hits;
      ASSERT_NEAR(*got, *want, kExact) << "origin " << p.transpose() << " angle " << a;
    }
  }
  EXPECT_GT(compared, 15000);
  EXPECT_GT(hits, compared / 2);
}

namespace {

// A 10 x 4 m room of walls (a feature map's world) and the same room as a 0.05 m grid.
std::shared_ptr<const SegmentWorld> room() {
  return std::make_shared<SegmentWorld>(
      std::vector<Segment>{{{0, 0}, {10, 0}}, {{10, 0}, {10, 4}}, {{10, 4}, {0, 4}}, {{0, 4}, {0, 0}}});
}

locd::sim::WorldDifferences differences(const std::string& yaml) {
  return locd::sim::parse_world_differences(locd::Params::parse(yaml, "differences.yaml"));
}

}  // namespace

TEST(WorldDifferences, ClutterAndWallsTheMapLacksStopBeams) {
  const locd::sim::DifferentWorld world(room(), differences(
      "clutter: [{centre: [5, 2], size: [1, 0.5], yaw_deg: 90}]\nwalls: [[[2, 3], [2, 4]]]\n"));
  EXPECT_NEAR(*world.cast({1, 2}, 0.0, 20.0), 3.75, kExact);     // the box turned 90 deg: 0.5 along x
  EXPECT_NEAR(*world.cast({1, 3.5}, 0.0, 20.0), 1.0, kExact);    // the wall the map lacks
  EXPECT_NEAR(*world.cast({1, 2.8}, 0.0, 20.0), 9.0, kExact);    // between them: the map's wall
}

TEST(WorldDifferences, APersonWalkingOccludesTheBeamsItCrosses) {
  // A person (radius 0.3) walks from (5, 0.5) to (5, 3.5) and back at 1 m/s.
  const locd::sim::DifferentWorld world(room(), differences("people: [{path: [[5, 0.5], [5, 3.5]], radius: 0.3, speed: 1}]\n"));
  const Eigen::Vector2d o(1, 2);
  EXPECT_NEAR(*world.cast_at(0.0, o, 0.0, 20.0), 9.0, kExact);   // at (5, 0.5): out of the beam
  EXPECT_NEAR(*world.cast_at(1.5, o, 0.0, 20.0), 3.7, kExact);   // at (5, 2): in it
  EXPECT_NEAR(*world.cast_at(4.5, o, 0.0, 20.0), 3.7, kExact);   // on the way back
  EXPECT_NEAR(*world.cast_at(3.0, o, 0.0, 20.0), 9.0, kExact);   // at (5, 3.5)
  // The share of a 180-degree scan it hides, every 0.1 s over one walk: some beams, never all.
  int hidden_scans = 0;
  for (double t = 0; t < 6.0; t += 0.1) {
    int hidden = 0;
    for (int i = 0; i < 181; ++i) {
      const double a = -M_PI / 2 + i * M_PI / 180;
      if (*world.cast_at(t, o, a, 20.0) + 1e-9 < *room()->cast(o, a, 20.0)) ++hidden;
    }
    EXPECT_LT(hidden, 30) << t;
    hidden_scans += hidden > 0;
  }
  EXPECT_GT(hidden_scans, 30);
}

TEST(WorldDifferences, GlassAndOpenDoorsLetTheBeamThroughClosedDoorsStopIt) {
  // The room split by a wall at x = 5 in its map; glass from y = 0 to 2 in it, a door from 2 to 3
  // open in the world; the doorway at x = 8 (none in the map) closed in the world.
  auto split = std::make_shared<SegmentWorld>(std::vector<Segment>{
      {{0, 0}, {10, 0}}, {{10, 0}, {10, 4}}, {{10, 4}, {0, 4}}, {{0, 4}, {0, 0}}, {{5, 0}, {5, 4}}});
  const locd::sim::DifferentWorld world(split, differences(
      "glass: [{from: [5, 0], to: [5, 2]}]\n"
      "doors: [{from: [5, 2], to: [5, 3], world: open}, {from: [8, 0], to: [8, 4], world: closed}]\n"));
  EXPECT_NEAR(*split->cast({1, 1}, 0.0, 20.0), 4.0, kExact);
  EXPECT_NEAR(*world.cast({1, 1}, 0.0, 20.0), 7.0, kExact);    // through the glass to the closed door
  EXPECT_NEAR(*world.cast({1, 2.5}, 0.0, 20.0), 7.0, kExact);  // through the open door
  EXPECT_NEAR(*world.cast({1, 3.5}, 0.0, 20.0), 4.0, kExact);  // the wall above the door
  EXPECT_NEAR(*world.cast({9, 1}, M_PI, 20.0), 1.0, kExact);   // the closed door from the other side
}

TEST(WorldDifferences, GlassInAGridWorldHidesTheMapsWallCells) {
  // The same split room as a 0.05 m grid: the wall at x = 5 is column 100; glass over its lower half.
  TestGrid grid(201, 81, 0.05);
  for (int c = 0; c <= 200; ++c) grid.set(0, c).set(80, c);
  for (int r = 0; r <= 80; ++r) grid.set(r, 0).set(r, 100).set(r, 200);
  auto base = std::make_shared<GridWorld>(grid.world());
  const locd::sim::DifferentWorld world(base, differences("glass: [{from: [5.025, 0.05], to: [5.025, 2]}]\n"));
  EXPECT_NEAR(*base->cast({1, 1}, 0.0, 20.0), 4.0, kExact);
  EXPECT_NEAR(*world.cast({1, 1}, 0.0, 20.0), 9.0, kExact);    // to the east wall's face at x = 10
  EXPECT_NEAR(*world.cast({1, 3}, 0.0, 20.0), 4.0, kExact);    // above the glass
  EXPECT_NEAR(*world.cast({9, 1}, M_PI, 20.0), 8.95, kExact);  // back, to the west wall's face at x = 0.05
}

TEST(WorldDifferences, AScaledMapScalesEveryRange) {
  // The world 1 % larger than its map, with a box the map lacks: every range 1.01 times the map's.
  const locd::sim::DifferentWorld world(room(), differences("map_scale: 1.01\nclutter: [{centre: [8, 3], size: [1, 1]}]\n"));
  EXPECT_NEAR(*world.cast({5, 2}, 0.0, 20.0), 5.0 * 1.01, kExact);
  EXPECT_NEAR(*world.cast({5, 2}, M_PI / 2, 20.0), 2.0 * 1.01, kExact);
  EXPECT_NEAR(*world.cast({5, 3}, 0.0, 20.0), 2.5 * 1.01, kExact);
  EXPECT_FALSE(world.cast({5, 2}, 0.0, 5.0));  // 5.05 m in the world: beyond 5 m
}

TEST(WorldDifferences, BadKeysNameKeyValueAndWhatIsAllowed) {
  const auto error = [](const std::string& yaml) {
    try {
      differences(yaml);
    } catch (const locd::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("mirrors: []\n").find("unknown parameter 'mirrors'"), std::string::npos) << error("mirrors: []\n");
  const std::string scale = error("map_scale: 2\n");
  EXPECT_NE(scale.find("'map_scale'"), std::string::npos) << scale;
  EXPECT_NE(scale.find("[0.9, 1.1]"), std::string::npos) << scale;
  const std::string door = error("doors: [{from: [1, 0], to: [2, 0], world: ajar}]\n");
  EXPECT_NE(door.find("'doors[0].world'"), std::string::npos) << door;
  EXPECT_NE(door.find("ajar"), std::string::npos) << door;
  EXPECT_NE(door.find("open"), std::string::npos) << door;
  const std::string box = error("clutter: [{centre: [1, 2], size: [0, 1]}]\n");
  EXPECT_NE(box.find("'clutter[0].size'"), std::string::npos) << box;
  const std::string person = error("people: [{path: [[1, 2], [1, 2]]}]\n");
  EXPECT_NE(person.find("'people[0].path'"), std::string::npos) << person;
  EXPECT_NE(person.find("repeats"), std::string::npos) << person;
  const std::string wall = error("walls: [[[1, 2]]]\n");
  EXPECT_NE(wall.find("'walls'"), std::string::npos) << wall;
  EXPECT_NE(error("glass: {from: [1, 2]}\n").find("is not a list"), std::string::npos);
  EXPECT_NE(error("glass: [{from: [1, 2]}]\n").find("'glass[0].to' (") , std::string::npos) << error("glass: [{from: [1, 2]}]\n");
}
