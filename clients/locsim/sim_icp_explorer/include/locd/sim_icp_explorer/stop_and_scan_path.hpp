// A stop-and-scan robot driven along a fixed list of stops (not the explorer's goals): at each
// stop the odometry (off by up to the configured bounds per leg) and a 3D scan go to the
// localizer, and what it returns is kept with the truth. The degeneracy tests and benchmark of
// icp_explorer drive it through the two-rooms-and-corridor world this way.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/plugin.hpp"
#include "locd/sim_icp_explorer/indoor_world.hpp"
#include "locd/sim_icp_explorer/scanner3d.hpp"
#include "locd/sim_icp_explorer/stop_and_scan_odometry.hpp"

namespace locd::sim {

struct PathScanRecord {
  Pose2 truth;
  std::optional<PoseEstimate> estimate;
  std::optional<LocalizationAssessment> localization;
  Diagnostics diagnostics;
};

// set_pose(stops[0]) (the true start), then per stop: odometry, scan (stamped 30 s apart), update.
std::vector<PathScanRecord> run_stop_and_scan_path(const IndoorWorld& world, const Scanner3DConfig& scanner,
                                                   const StopAndScanOdometryConfig& odometry,
                                                   const std::vector<Pose2>& stops, uint64_t seed, Localizer& localizer);

// The stops through config/maps/two_rooms_corridor_3d.yaml: two in room A, then every `step` m
// along the corridor's middle (y = 4), then two in room B.
std::vector<Pose2> two_rooms_corridor_stops(double step = 4.5);

// The error of an estimate against the truth in the map frame: (x, y, z, roll, pitch, yaw), the
// angles of truth^-1 * estimate's rotation (small).
Eigen::Matrix<double, 6, 1> pose_error(const PoseEstimate& estimate, const Pose2& truth);

}  // namespace locd::sim
