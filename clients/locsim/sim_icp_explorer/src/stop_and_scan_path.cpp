#include "locd/sim_icp_explorer/stop_and_scan_path.hpp"

#include <random>

namespace locd::sim {

std::vector<PathScanRecord> run_stop_and_scan_path(const IndoorWorld& world, const Scanner3DConfig& scanner_config,
                                                   const StopAndScanOdometryConfig& odometry_config,
                                                   const std::vector<Pose2>& stops, uint64_t seed, Localizer& localizer) {
  std::vector<PathScanRecord> records;
  if (stops.empty()) return records;
  const Scanner3D scanner(scanner_config);
  StopAndScanOdometry odometry(odometry_config);
  std::mt19937_64 rng(seed);
  PoseEstimate start;
  start.header = {1, "map"};
  start.pose = stops.front().to_isometry();
  localizer.set_pose(start);
  for (size_t k = 0; k < stops.size(); ++k) {
    const int64_t stamp = static_cast<int64_t>(k + 1) * 30'000'000'000LL;
    localizer.update(odometry.arrive(stops[k], stamp - 1'000'000, rng));
    const SimulatedScan scan = scanner.scan(world, stops[k].to_isometry(), static_cast<double>(k) * 30.0, stamp, rng);
    const UpdateResult out = localizer.update(scan.cloud);
    records.push_back({stops[k], out.estimate, out.localization, out.diagnostics});
  }
  return records;
}

std::vector<Pose2> two_rooms_corridor_stops(double step) {
  std::vector<Pose2> stops{Pose2(4.0, 4.0, 0.0), Pose2(6.0, 2.5, 0.3)};
  for (double x = 10.0; x < 66.0; x += step) stops.emplace_back(x, 4.0, 0.0);
  stops.emplace_back(70.0, 4.0, 0.0);
  stops.emplace_back(72.5, 3.0, -0.5);
  return stops;
}

Eigen::Matrix<double, 6, 1> pose_error(const PoseEstimate& estimate, const Pose2& truth) {
  const Eigen::Isometry3d T = truth.to_isometry();
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = estimate.pose.translation() - T.translation();
  // Small rotation error, as (roll, pitch, yaw) of the difference in the map frame.
  const Eigen::AngleAxisd d(estimate.pose.linear() * T.linear().transpose());
  e.tail<3>() = d.angle() * d.axis();
  return e;
}

}  // namespace locd::sim
