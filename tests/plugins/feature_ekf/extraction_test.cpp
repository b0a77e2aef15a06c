// Line, corner and edge extraction on scans ray-cast against known walls.
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "locd/feature_ekf/laser_feature_extractor.hpp"
#include "locd/sdk/geometry.hpp"
#include "synthetic_scan.hpp"

using namespace locd;
using namespace locd::feature_ekf;

namespace {

// A closed room (-2, -3) .. (4, 2) with the robot at the origin looking along +x: it sees the
// wall x = 4 between the concave corners (4, -3) and (4, 2). The laser sits 0.1 m ahead.
const char* kRoom = R"(
walls:
  - [[-2, -3], [4, -3], [4, 2], [-2, 2]]
closed: [true]
)";

// The same kind of room, larger, with a free-standing panel x = 3, y in [0.5, 2] in front of
// the far wall: both panel ends occlude the far wall.
const char* kRoomWithPanel = R"(
walls:
  - [[-2, -6], [8, -6], [8, 6], [-2, 6]]
  - [[3, 0.5], [3, 2]]
closed: [true, false]
)";

ExtractorConfig without_floors() {
  ExtractorConfig c;
  c.line_rho_stddev = c.line_alpha_stddev = c.point_range_stddev = c.point_bearing_stddev = 0.0;
  return c;
}

const ExtractedLine* find_line(const ExtractedFeatures& f, double r, double phi) {
  for (const ExtractedLine& l : f.lines) {
    if (std::abs(l.z.x() - r) < 0.2 && std::abs(normalize_angle(l.z.y() - phi)) < 0.1) return &l;
  }
  return nullptr;
}

}  // namespace

TEST(LaserFeatureExtractor, NoiselessWallsGiveExactLines) {
  const FeatureMap2D room = test::map_from_walls(kRoom);
  test::ScanGeometry geometry;
  const LaserScan scan = test::ray_cast_scan(room.lines, Pose2(0, 0, 0), geometry);
  const ExtractedFeatures f = LaserFeatureExtractor(without_floors()).extract(scan);
  EXPECT_EQ(f.usable_returns, 361u);
  const ExtractedLine* far_wall = find_line(f, 4.0, 0.0);
  const ExtractedLine* left_wall = find_line(f, 2.0, M_PI / 2);
  const ExtractedLine* right_wall = find_line(f, 3.0, -M_PI / 2);
  ASSERT_NE(far_wall, nullptr);
  ASSERT_NE(left_wall, nullptr);
  ASSERT_NE(right_wall, nullptr);
  EXPECT_NEAR(far_wall->z.x(), 4.0, 1e-4);
  EXPECT_NEAR(far_wall->z.y(), 0.0, 1e-4);
  EXPECT_NEAR(left_wall->z.x(), 2.0, 1e-4);
  EXPECT_EQ(f.lines.size(), 3u);
  EXPECT_TRUE(f.edges.empty());
}

TEST(LaserFeatureExtractor, RecoversLinesWithinTheirCovariance) {
  // Over many noisy scans the normalized squared error of (r, phi) averages the dimension (2).
  const FeatureMap2D room = test::map_from_walls(kRoom);
  test::ScanGeometry geometry;
  const Pose2 robot(0.3, -0.4, 0.25);
  const LineFeature& far_wall_map = room.lines[1];  // (4, -3) -> (4, 2)
  const Pose2 inverse = robot.inverse();
  // The wall in the robot frame: normal form of its transformed end points.
  const LineFeature far_wall_robot{"", inverse.transform(far_wall_map.a), inverse.transform(far_wall_map.b)};
  const LaserFeatureExtractor extractor(without_floors());
  std::mt19937_64 rng(11);
  double nees_sum = 0.0;
  int found = 0;
  const int trials = 300;
  for (int trial = 0; trial < trials; ++trial) {
    const LaserScan scan = test::ray_cast_scan(room.lines, robot, geometry, &rng);
    const ExtractedFeatures f = extractor.extract(scan);
    const ExtractedLine* line = find_line(f, far_wall_robot.rho(), far_wall_robot.alpha());
    if (!line) continue;
    ++found;
    const Eigen::Vector2d error(line->z.x() - far_wall_robot.rho(), normalize_angle(line->z.y() - far_wall_robot.alpha()));
    EXPECT_LT(std::abs(error.x()), 0.01);
    EXPECT_LT(std::abs(error.y()), 0.01);
    nees_sum += error.dot(line->covariance.inverse() * error);
  }
  ASSERT_EQ(found, trials);
  const double mean_nees = nees_sum / trials;
  EXPECT_GT(mean_nees, 1.5);
  EXPECT_LT(mean_nees, 2.6);
}

TEST(LaserFeatureExtractor, FindsTheCornersOfTheRoom) {
  const FeatureMap2D room = test::map_from_walls(kRoom);
  test::ScanGeometry geometry;
  std::mt19937_64 rng(5);
  const LaserScan scan = test::ray_cast_scan(room.lines, Pose2(0, 0, 0), geometry, &rng);
  const ExtractedFeatures f = LaserFeatureExtractor().extract(scan);
  ASSERT_EQ(f.corners.size(), 2u);
  EXPECT_LT((f.corners[0].position - Eigen::Vector2d(4, -3)).norm(), 0.03);
  EXPECT_LT((f.corners[1].position - Eigen::Vector2d(4, 2)).norm(), 0.03);
  EXPECT_NEAR(f.corners[1].z.x(), std::hypot(4.0, 2.0), 0.03);
  EXPECT_NEAR(f.corners[1].z.y(), std::atan2(2.0, 4.0), 0.01);
  EXPECT_TRUE(f.edges.empty());
}

TEST(LaserFeatureExtractor, NoCornerWhereLinesMeetAtAShallowAngle) {
  // Two walls meeting at 20 deg: a bend, not a corner.
  const FeatureMap2D map = test::map_from_walls(R"(
walls:
  - [[3, -4], [3, 0], [4.5, 4.12]]
)");
  const LaserScan scan = test::ray_cast_scan(map.lines, Pose2(0, 0, 0), test::ScanGeometry{});
  const ExtractedFeatures f = LaserFeatureExtractor().extract(scan);
  EXPECT_EQ(f.lines.size(), 2u);
  EXPECT_TRUE(f.corners.empty());
}

TEST(LaserFeatureExtractor, FindsOccludingEdgesOnlyOnTheNearerSurface) {
  const FeatureMap2D map = test::map_from_walls(kRoomWithPanel);
  std::mt19937_64 rng(9);
  const LaserScan scan = test::ray_cast_scan(map.lines, Pose2(0, 0, 0), test::ScanGeometry{}, &rng);
  const ExtractedFeatures f = LaserFeatureExtractor().extract(scan);
  ASSERT_EQ(f.edges.size(), 2u);
  EXPECT_LT((f.edges[0].position - Eigen::Vector2d(3, 0.5)).norm(), 0.03);
  EXPECT_LT((f.edges[1].position - Eigen::Vector2d(3, 2)).norm(), 0.03);
  // Within their stated uncertainty.
  for (const auto& [edge, truth] : {std::pair{f.edges[0], Eigen::Vector2d(3, 0.5)}, std::pair{f.edges[1], Eigen::Vector2d(3, 2)}}) {
    const Eigen::Vector2d z_true(truth.norm(), std::atan2(truth.y(), truth.x()));
    const Eigen::Vector2d error = edge.z - z_true;
    EXPECT_LT(error.dot(edge.covariance.inverse() * error), 13.8);  // chi-square(2) 99.9 %
  }
  // The panel itself is a line.
  EXPECT_NE(find_line(f, 3.0, 0.0), nullptr);
}

TEST(LaserFeatureExtractor, OpenSpaceBehindAWallEndMakesAnEdge) {
  // A single wall ending in the field of view, nothing behind it.
  const FeatureMap2D map = test::map_from_walls("walls:\n  - [[4, -1], [4, 3]]\n");
  const LaserScan scan = test::ray_cast_scan(map.lines, Pose2(0, 0, 0), test::ScanGeometry{});
  const ExtractedFeatures f = LaserFeatureExtractor().extract(scan);
  ASSERT_EQ(f.lines.size(), 1u);
  ASSERT_EQ(f.edges.size(), 2u);
  EXPECT_LT((f.edges[0].position - Eigen::Vector2d(4, -1)).norm(), 0.03);
  EXPECT_LT((f.edges[1].position - Eigen::Vector2d(4, 3)).norm(), 0.03);
}

TEST(LaserFeatureExtractor, SensorOffsetAndRotationAreApplied) {
  const FeatureMap2D room = test::map_from_walls(kRoom);
  test::ScanGeometry geometry;
  geometry.sensor_in_base = Pose2(0.5, 0.2, 0.3);
  const LaserScan scan = test::ray_cast_scan(room.lines, Pose2(0, 0, 0), geometry);
  const ExtractedFeatures f = LaserFeatureExtractor(without_floors()).extract(scan);
  const ExtractedLine* far_wall = find_line(f, 4.0, 0.0);
  ASSERT_NE(far_wall, nullptr);
  EXPECT_NEAR(far_wall->z.x(), 4.0, 1e-4);
  EXPECT_NEAR(far_wall->z.y(), 0.0, 1e-4);
}

TEST(LaserFeatureExtractor, ErroneousReadingsDoNotBreakAWall) {
  // REP 117: NaN and zero readings say nothing, so a wall runs on across them and gives the same
  // line.
  const FeatureMap2D room = test::map_from_walls(kRoom);
  const LaserScan clean = test::ray_cast_scan(room.lines, Pose2(0, 0, 0), test::ScanGeometry{});
  const LaserFeatureExtractor extractor(without_floors());
  const ExtractedFeatures reference = extractor.extract(clean);
  const ExtractedLine* far_wall = find_line(reference, 4.0, 0.0);
  ASSERT_NE(far_wall, nullptr);
  for (const float reading : {std::numeric_limits<float>::quiet_NaN(), 0.0f}) {
    LaserScan dropped = clean;
    for (size_t i = 3; i < dropped.ranges.size(); i += 7) dropped.ranges[i] = reading;
    const ExtractedFeatures f = extractor.extract(dropped);
    EXPECT_EQ(f.lines.size(), reference.lines.size()) << reading;
    const ExtractedLine* line = find_line(f, 4.0, 0.0);
    ASSERT_NE(line, nullptr) << reading;
    EXPECT_NEAR(line->z.x(), far_wall->z.x(), 1e-6);
    EXPECT_NEAR(line->z.y(), far_wall->z.y(), 1e-6);
    EXPECT_LE(line->first_beam, far_wall->first_beam + 1) << "a dropped end beam moves the end by one beam at most";
    EXPECT_GE(line->last_beam + 1, far_wall->last_beam);
  }
  // A dropout of up to two no-return or too-close beams amid a wall is looked across; three or
  // more are something else seen there (or nothing: a door) and split it.
  const size_t middle = (far_wall->first_beam + far_wall->last_beam) / 2;
  const float inf = std::numeric_limits<float>::infinity();
  for (const float reading : {inf, -inf}) {
    for (size_t run = 1; run <= 4; ++run) {
      LaserScan gap = clean;
      for (size_t i = 0; i < run; ++i) gap.ranges[middle + i] = reading;
      const ExtractedFeatures f = extractor.extract(gap);
      EXPECT_EQ(f.lines.size(), reference.lines.size() + (run > 2 ? 1 : 0)) << reading << " x" << run;
    }
  }
}

TEST(LaserFeatureExtractor, ScanWithoutReturnsGivesNoFeatures) {
  LaserScan scan;
  scan.angle_min = -1.0f;
  scan.angle_increment = 0.01f;
  scan.range_min = 0.1f;
  scan.range_max = 10.0f;
  scan.ranges.assign(200, std::numeric_limits<float>::quiet_NaN());
  const ExtractedFeatures f = LaserFeatureExtractor().extract(scan);
  EXPECT_EQ(f.usable_returns, 0u);
  EXPECT_TRUE(f.lines.empty());
}
