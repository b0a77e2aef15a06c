#include <gtest/gtest.h>

#include <random>

#include "locd/sdk/feature_map.hpp"
#include "locd/sim/world.hpp"
#include "locsim_paths.hpp"

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
