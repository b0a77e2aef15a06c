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
#include "locd/icp_explorer/nearest_frontier.hpp"
#include "locd/icp_explorer/icp_explorer.hpp"
#include "locd/sim_icp_explorer/stop_and_scan_odometry.hpp"
#include "locd/sim_icp_explorer/surface_coverage.hpp"

namespace locd::bench {

enum class Strategy { kNextBestView, kNearestFrontier };

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
  size_t model_voxels = 0;          // the registered model at the end
  size_t ghost_voxels = 0;          // of them, farther than 0.15 m from every static surface
};

// carve_free_space: the model's ghost carving (VoxelMap::carve), on by default.
inline ExplorationRun explore(Strategy strategy, uint64_t seed, int max_scans, double target_coverage,
                              const sim::SurfaceCoverage& reference, const sim::IndoorWorld& world,
                              bool carve_free_space = true) {
  sim::SurfaceCoverage coverage = reference;
  const sim::Scanner3D scanner{sim::Scanner3DConfig{}};
  const icp_explorer::IcpExplorerConfig config = [&] {
    auto c = four_rooms_config();
    c.exploration = strategy == Strategy::kNextBestView;
    c.carve_free_space = carve_free_space;
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
      goal = icp_explorer::nearest_frontier(frontier_map, planner, here, stops, 1.0);
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
  run.model_voxels = explorer.model().size();
  for (const Eigen::Vector3d& p : explorer.model().points()) run.ghost_voxels += world.distance_to_static(p) > 0.15;
  return run;
}

}  // namespace locd::bench
