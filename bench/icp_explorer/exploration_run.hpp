// One exploration of the four-room world: the robot stops, scans (full-size scan, people
// walking), registers the scan with the modified ICP from odometry that is off by up to 0.5 m and
// 10 degrees per leg, and goes to the next scan position chosen either by the next-best-view
// planner (layered hexahedral map, eq. 2-4) or by the nearest-frontier baseline. Coverage of the
// observable static surface is measured on the true hit points after every scan.
#pragma once

#include <limits>
#include <random>
#include <vector>

#include "four_rooms_pair.hpp"
#include "locd/icp_explorer/icp_explorer.hpp"
#include "locd/sim_icp_explorer/stop_and_scan_odometry.hpp"
#include "locd/sim_icp_explorer/surface_coverage.hpp"

namespace locd::bench {

enum class Strategy { kNextBestView, kNearestFrontier };

// Nearest-frontier exploration (Yamauchi 1997) on the same map collapsed to 2D (a column is
// occupied / empty / unknown below the robot's height): a frontier is an empty column next to an
// unknown one; the goal is the nearest reachable scan position (the planner's movable columns:
// footprint known empty) with a frontier within its footprint plus one cell, at least
// min_distance away and at least min_distance from every earlier scan stop (a frontier that one
// scan did not resolve is not tried again); done when there is none.
inline std::optional<Eigen::Vector2d> nearest_frontier(const icp_explorer::LayeredHexahedralMap& map,
                                                       const icp_explorer::NextBestViewPlanner& planner,
                                                       const Eigen::Vector2d& robot,
                                                       const std::vector<Eigen::Vector2d>& scan_stops,
                                                       double min_distance) {
  using icp_explorer::CellState;
  std::vector<float> length;
  const std::vector<float> m = planner.movable(map, robot, &length);
  const double height = planner.settings().robot_height;
  const int columns = map.columns(), rows = map.rows();
  // Frontier columns: empty, with an unknown 4-neighbour (the edge of the known free space).
  std::vector<CellState> state(static_cast<size_t>(columns) * rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c) state[static_cast<size_t>(r) * columns + c] = map.column_state(c, r, height);
  auto at = [&](int c, int r) {
    return (c < 0 || r < 0 || c >= columns || r >= rows) ? CellState::kOccupied : state[static_cast<size_t>(r) * columns + c];
  };
  std::vector<char> frontier(state.size(), 0);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      frontier[static_cast<size_t>(r) * columns + c] =
          at(c, r) == CellState::kEmpty && (at(c + 1, r) == CellState::kUnknown || at(c - 1, r) == CellState::kUnknown ||
                                            at(c, r + 1) == CellState::kUnknown || at(c, r - 1) == CellState::kUnknown);
  // A scan position serves a frontier within its footprint plus one cell.
  const int reach = static_cast<int>(std::ceil(planner.settings().robot_radius / map.settings().cell_size)) + 1;
  std::optional<Eigen::Vector2d> best;
  double best_length = std::numeric_limits<double>::infinity();
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c) {
      const size_t i = static_cast<size_t>(r) * columns + c;
      if (m[i] < 1.0f || length[i] < min_distance || length[i] >= best_length) continue;
      const Eigen::Vector2d xy = map.column_centre(c, r);
      bool visited = false;
      for (const auto& stop : scan_stops) visited |= (stop - xy).norm() < min_distance;
      if (visited) continue;
      bool serves = false;
      for (int dr = -reach; dr <= reach && !serves; ++dr)
        for (int dc = -reach; dc <= reach && !serves; ++dc) {
          const int rr = r + dr, cc = c + dc;
          serves = rr >= 0 && cc >= 0 && rr < rows && cc < columns && frontier[static_cast<size_t>(rr) * columns + cc];
        }
      if (!serves) continue;
      best_length = length[i];
      best = xy;
    }
  return best;
}

inline icp_explorer::IcpExplorerConfig four_rooms_config() {
  icp_explorer::IcpExplorerConfig c;
  c.layered_map.origin = {-0.5, -0.5};
  c.layered_map.size = {17.0, 17.0};
  return c;
}

struct ExplorationRun {
  int scans = 0;
  int scans_to_target = -1;         // first scan count reaching the target coverage
  int scans_to_90 = -1;             // first scan count reaching 90 % coverage
  double coverage = 0.0;            // after the last scan
  double path_length = 0.0;         // m, straight legs between scan stops
  double max_error_cm = 0.0;        // registration error, worst scan
  double max_error_deg = 0.0;
  bool done = false;                // the strategy declared the world explored
};

inline ExplorationRun explore(Strategy strategy, uint64_t seed, int max_scans, double target_coverage,
                              const sim::SurfaceCoverage& reference, const sim::IndoorWorld& world) {
  sim::SurfaceCoverage coverage = reference;
  const sim::Scanner3D scanner{sim::Scanner3DConfig{}};
  const icp_explorer::IcpExplorerConfig config = [&] {
    auto c = four_rooms_config();
    c.exploration = strategy == Strategy::kNextBestView;
    return c;
  }();
  icp_explorer::IcpExplorer explorer(config);
  icp_explorer::LayeredHexahedralMap frontier_map(config.layered_map);
  const icp_explorer::NextBestViewPlanner planner(config.planner);
  sim::StopAndScanOdometry odometry{sim::StopAndScanOdometryConfig{}};
  std::mt19937_64 rng(seed);
  Pose2 truth(3.0, 3.0, 0.0);
  explorer.set_pose(truth.to_isometry());
  ExplorationRun run;
  std::vector<Eigen::Vector2d> stops;
  for (int k = 0; k < max_scans; ++k) {
    const int64_t stamp = (k + 1) * 30'000'000'000LL;
    explorer.add_odometry(odometry.arrive(truth, stamp, rng));
    const sim::SimulatedScan scan = scanner.scan(world, truth.to_isometry(), k * 30.0, stamp, rng);
    coverage.add(scan, world);
    const icp_explorer::ScanOutcome outcome = explorer.add_scan(scan.cloud);
    run.scans = k + 1;
    run.coverage = coverage.ratio();
    run.max_error_cm = std::max(run.max_error_cm, 100.0 * translation_error(outcome.T_map_base, truth.to_isometry()));
    run.max_error_deg = std::max(run.max_error_deg, rotation_error_deg(outcome.T_map_base, truth.to_isometry()));
    if (run.scans_to_90 < 0 && run.coverage >= 0.9) run.scans_to_90 = run.scans;
    if (run.scans_to_target < 0 && run.coverage >= target_coverage) {
      run.scans_to_target = run.scans;
      break;
    }
    const Eigen::Vector2d here = outcome.T_map_base.translation().head<2>();
    std::optional<Eigen::Vector2d> goal;
    if (strategy == Strategy::kNextBestView) {
      if (!outcome.exploration->done) goal = outcome.exploration->goal;
    } else {
      const icp_explorer::ScanPoints rays = icp_explorer::voxel_downsample(
          scan.cloud.points, {}, 0.5 * config.layered_map.cell_size, outcome.T_map_base * scan.cloud.sensor_pose);
      frontier_map.integrate(rays.points, (outcome.T_map_base * scan.cloud.sensor_pose).translation());
      stops.push_back(here);
      goal = nearest_frontier(frontier_map, planner, here, stops, 1.0);
    }
    if (!goal) {
      run.done = true;
      break;
    }
    // The robot drives to the goal (given in the map frame, which the registration keeps on the
    // world frame) and faces its direction of travel.
    const Eigen::Vector2d step = *goal - here;
    run.path_length += step.norm();
    truth = Pose2(goal->x(), goal->y(), std::atan2(step.y(), step.x()));
  }
  return run;
}

}  // namespace locd::bench
