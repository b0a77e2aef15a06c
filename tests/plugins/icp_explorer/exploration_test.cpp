// Map scores on a toy world: the layered hexahedral map's cube states, detection probability and
// conflicted columns; the movable / exploratory / resumable terms, S = m (e + beta rs) (eq. 2),
// the reliable-distance weight and direction term (eq. 3, 4), the chosen goal and the done state.
#include <gtest/gtest.h>

#include <cmath>

#include "locd/icp_explorer/layered_hexahedral_map.hpp"
#include "locd/icp_explorer/next_best_view.hpp"
#include "toy_world.hpp"

namespace ie = locd::icp_explorer;
using locd::Pose2;

namespace {

ie::LayeredMapSettings toy_settings(const locd::sim::Scanner3D& scanner) {
  ie::LayeredMapSettings s;
  s.origin = {-0.5, -0.5};
  s.size = {11.0, 5.0};
  s.cell_size = 0.25;
  s.layer_height = 0.4;
  s.z_min = 0.1;
  s.z_max = 2.3;
  s.azimuth_step = scanner.azimuth_step();
  s.elevation_step = scanner.elevation_step();
  return s;
}

ie::ExplorationSettings planner_settings() {
  ie::ExplorationSettings e;
  e.max_range = 15.0;
  e.rays = 90;
  e.candidate_stride = 2;
  e.done_threshold = 5.0;
  return e;
}

// Room A scanned once from (3, 1.2): room B is only seen through the door.
struct ScannedRoomA {
  locd::sim::IndoorWorld world = locd::test::two_rooms();
  locd::sim::Scanner3D scanner{locd::test::coarse_scanner()};
  ie::LayeredHexahedralMap map{toy_settings(scanner)};
  Eigen::Vector2d robot{3.0, 1.2};
  ScannedRoomA() {
    const Eigen::Isometry3d pose = Pose2(robot.x(), robot.y(), 0.0).to_isometry();
    const auto points = locd::test::scan_in_map(world, scanner, pose, 0.1, 5);
    map.integrate(points.points, (pose * scanner.sensor_in_base()).translation());
  }
  ie::CellState at(double x, double y, double z) const {
    int c = 0, r = 0;
    EXPECT_TRUE(map.column_of({x, y}, c, r));
    const int layer = static_cast<int>(std::floor((z - map.settings().z_min) / map.settings().layer_height));
    return map.state(layer, c, r);
  }
};

}  // namespace

TEST(LayeredHexahedralMap, DetectionGrowsWithPointsAndCountsFewFarPointsMore) {
  const locd::sim::Scanner3D scanner(locd::test::coarse_scanner());
  const ie::LayeredHexahedralMap map(toy_settings(scanner));
  EXPECT_DOUBLE_EQ(map.detection(2.0, 0.0), 0.0);
  EXPECT_LT(map.detection(2.0, 1.0), map.detection(2.0, 3.0));
  EXPECT_LE(map.detection(1.0, 2.0), map.detection(10.0, 2.0)) << "two points far away are stronger evidence";
  EXPECT_GT(map.detection_from(1.0), map.detection_from(12.0)) << "a far cube is harder to detect";
  EXPECT_GT(map.expected_returns(1.0), map.expected_returns(2.0) * 3.9);
}

TEST(LayeredHexahedralMap, WallsOccupiedRoomEmptyBehindWallsUnknown) {
  const ScannedRoomA a;
  EXPECT_EQ(a.at(-0.1, 2.0, 1.0), ie::CellState::kOccupied);  // west wall
  EXPECT_EQ(a.at(3.0, 3.95, 1.5), ie::CellState::kOccupied);  // north wall
  EXPECT_EQ(a.at(4.0, 2.0, 1.0), ie::CellState::kEmpty);      // open room A
  EXPECT_EQ(a.at(8.0, 0.6, 1.0), ie::CellState::kUnknown);    // room B beside the door, hidden
  EXPECT_EQ(a.at(7.0, 2.0, 1.0), ie::CellState::kEmpty);      // room B straight through the door
  EXPECT_GT(a.map.cells_in_state(ie::CellState::kUnknown), 0u);
}

TEST(LayeredHexahedralMap, ColumnBehindTheCrateIsConflicted) {
  const ScannedRoomA a;
  // Behind the 1.1 m crate (seen from the robot) the low layers are hidden, the high ones seen:
  // a partially scanned column.
  int c = 0, r = 0;
  ASSERT_TRUE(a.map.column_of({5.65, 0.6}, c, r));
  EXPECT_EQ(a.map.state(0, c, r), ie::CellState::kUnknown);
  EXPECT_EQ(a.map.state(a.map.layers() - 1, c, r), ie::CellState::kEmpty);
  EXPECT_TRUE(a.map.conflicted(c, r));
  ASSERT_TRUE(a.map.column_of({4.0, 2.0}, c, r));
  EXPECT_FALSE(a.map.conflicted(c, r)) << "an open, fully seen column";
  EXPECT_GT(a.map.conflicted_columns(), 0u);
}

TEST(NextBestView, MovableOnlyOverEmptyColumnsAndPossiblyMovableThroughUnknown) {
  const ScannedRoomA a;
  ie::ExplorationSettings settings = planner_settings();
  settings.possibly_movable_weight = 0.3;
  const ie::NextBestViewPlanner planner(settings);
  std::vector<float> length;
  const auto m = planner.movable(a.map, a.robot, &length);
  int c = 0, r = 0;
  ASSERT_TRUE(a.map.column_of({4.0, 2.0}, c, r));
  EXPECT_EQ(m[static_cast<size_t>(r) * a.map.columns() + c], 1.0f);
  const float path = length[static_cast<size_t>(r) * a.map.columns() + c];
  EXPECT_GE(path, 1.2f) << "at least the straight line (1.28 m) less half a cell";
  EXPECT_LE(path, 1.7f);
  ASSERT_TRUE(a.map.column_of({-0.3, 2.0}, c, r));
  EXPECT_EQ(m[static_cast<size_t>(r) * a.map.columns() + c], 0.0f) << "wall: immovable";
  ASSERT_TRUE(a.map.column_of({8.5, 0.6}, c, r));
  EXPECT_EQ(m[static_cast<size_t>(r) * a.map.columns() + c], 0.0f) << "unknown: not a scan position";
}

TEST(NextBestView, ScoreIsEquationFourOfTheTerms) {
  const ScannedRoomA a;
  const ie::NextBestViewPlanner planner(planner_settings());
  ie::ExplorationTerms terms;
  const auto d = planner.decide(a.map, a.robot, {}, &terms);
  ASSERT_FALSE(d.done);
  EXPECT_GT(d.exploratory, 0.0);
  const double S = d.movable * (d.exploratory + planner.settings().beta * d.resumable);  // eq. 2
  EXPECT_NEAR(d.score, d.reliability * S * d.direction, 1e-9 * std::max(1.0, d.score));  // eq. 4, alpha = 1
  // It is the maximum of the score grid.
  float best = 0.0f;
  for (float v : terms.score.cells)
    if (std::isfinite(v)) best = std::max(best, v);
  EXPECT_NEAR(best, d.score, 1e-3 * d.score);
  // The goal looks into room B: at the door or beyond, not deep in room A.
  EXPECT_GT(d.goal.x(), 4.5);
}

TEST(NextBestView, ResumableCountsOnlyConflictedColumnsAndBetaWeighsIt) {
  const ScannedRoomA a;
  ie::ExplorationSettings settings = planner_settings();
  const ie::NextBestViewPlanner planner(settings);
  int c = 0, r = 0;
  ASSERT_TRUE(a.map.column_of({5.0, 1.9}, c, r));  // past the crate
  const auto [e, rs] = planner.exploratory_and_resumable(a.map, c, r);
  EXPECT_GT(rs, 0.0) << "sees the hidden floor behind the crate";
  EXPECT_LE(rs, e);
  settings.beta = 0.0;
  ie::ExplorationTerms with_beta, without_beta;
  planner.decide(a.map, a.robot, {}, &with_beta);
  ie::NextBestViewPlanner(settings).decide(a.map, a.robot, {}, &without_beta);
  const size_t i = static_cast<size_t>(r) * a.map.columns() + c;
  if (std::isfinite(with_beta.score.cells[i]))
    EXPECT_GT(with_beta.score.cells[i], without_beta.score.cells[i]);
}

TEST(NextBestView, ReliableDistanceAndDirectionTerms) {
  const ie::NextBestViewPlanner planner(planner_settings());
  EXPECT_DOUBLE_EQ(planner.reliability(0.0), 0.0) << "scanning where it stands adds nothing";
  EXPECT_LT(planner.reliability(0.5), planner.reliability(3.0));
  EXPECT_GT(planner.reliability(4.0), planner.reliability(12.0)) << "beyond the reliable distance";
  const Eigen::Vector2d robot(5, 5);
  const std::vector<Eigen::Vector2d> visited = {{2, 5}};
  EXPECT_NEAR(planner.direction_term(robot, {3, 5}, visited), 1.0 - planner.settings().direction_penalty, 1e-12);
  EXPECT_DOUBLE_EQ(planner.direction_term(robot, {8, 5}, visited), 1.0);
  EXPECT_DOUBLE_EQ(planner.direction_term(robot, {5, 8}, visited), 1.0);
}

TEST(NextBestView, DoneWhenNothingScoresAboveTheThreshold) {
  const ScannedRoomA a;
  ie::ExplorationSettings settings = planner_settings();
  settings.done_threshold = 1e9;
  const auto d = ie::NextBestViewPlanner(settings).decide(a.map, a.robot, {});
  EXPECT_TRUE(d.done);
  // A fully explored toy: scans from both rooms and the door leave little to gain.
  ScannedRoomA b;
  for (const Pose2& p : {Pose2(8.0, 2.0, 0.0), Pose2(6.1, 2.0, 0.0), Pose2(1.5, 1.0, 0.0), Pose2(9.0, 1.0, 0.0)}) {
    const auto points = locd::test::scan_in_map(b.world, b.scanner, p.to_isometry(), 0.1, 7);
    b.map.integrate(points.points, (p.to_isometry() * b.scanner.sensor_in_base()).translation());
  }
  const auto before = ie::NextBestViewPlanner(planner_settings()).decide(a.map, a.robot, {});
  const auto after = ie::NextBestViewPlanner(planner_settings()).decide(b.map, b.robot, {});
  EXPECT_LT(after.score, before.score);
}
