// The whole filter on a small synthetic building: from an offset initial pose, with drifting
// odometry, the error shrinks well below the odometry's drift.
#include <gtest/gtest.h>

#include <iostream>
#include <random>

#include "test_env.hpp"

#include "locd/feature_ekf/feature_ekf_filter.hpp"
#include "synthetic_scan.hpp"

using namespace locd;
using namespace locd::feature_ekf;

namespace {

// A 12 x 8 m room with a free-standing panel and an L-shaped wall (lines, corners, edges).
const char* kBuilding = R"(
walls:
  - [[0, 0], [12, 0], [12, 8], [0, 8]]
  - [[6, 3], [6, 5]]
  - [[2, 6], [3.5, 6], [3.5, 7]]
closed: [true, false, false]
)";

struct RunResult {
  double final_error = 0.0;
  double final_heading_error = 0.0;
  double mean_error_last_10s = 0.0;
  double dead_reckoning_error = 0.0;
  double matched_per_scan = 0.0;
};

// Drives a circle of radius 2.5 m around the panel at 0.8 m/s for `seconds`; odometry at 50 Hz
// with 3 % scale error and 0.02 rad/s yaw-rate bias, scans at 25 Hz.
RunResult drive(FeatureEkfFilter& filter, double seconds, uint64_t seed) {
  const FeatureMap2D& map = filter.map();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  const double speed = 0.8, yaw_rate = speed / 2.5, dt = 0.02;
  Pose2 truth(6.0, 1.5, 0.0);
  Pose2 odometry(0.0, 0.0, 0.0);  // odom frame starts at the origin
  const Pose2 odom_to_map = truth;
  RunResult result;
  double error_sum = 0.0;
  int error_count = 0, scans = 0, matched = 0;
  const int steps = static_cast<int>(seconds / dt);
  filter.apply_odometry(odometry, 0);
  for (int k = 1; k <= steps; ++k) {
    const Pose2 true_step(speed * dt, 0.0, yaw_rate * dt);
    truth = truth * true_step;
    const Pose2 measured_step(speed * dt * (1.03 + 0.01 * unit(rng)), 0.0,
                              (yaw_rate + 0.02 + 0.01 * unit(rng)) * dt);
    odometry = odometry * measured_step;
    const int64_t stamp = static_cast<int64_t>(k) * 20'000'000;
    filter.apply_odometry(odometry, stamp);
    if (k % 2 == 0) {
      const LaserScan scan = test::ray_cast_scan(map.lines, truth, test::ScanGeometry{}, &rng);
      const ScanUpdateReport report = filter.update(scan);
      ++scans;
      matched += static_cast<int>(report.matched[0] + report.matched[1] + report.matched[2]);
      const double error = (filter.pose().head<2>() - truth.vector().head<2>()).norm();
      if (k * dt > seconds - 10.0) {
        error_sum += error;
        ++error_count;
      }
    }
  }
  const Pose2 dead_reckoning = odom_to_map * odometry;
  result.dead_reckoning_error = (dead_reckoning.vector().head<2>() - truth.vector().head<2>()).norm();
  result.final_error = (filter.pose().head<2>() - truth.vector().head<2>()).norm();
  result.final_heading_error = std::abs(normalize_angle(filter.pose().z() - truth.theta));
  result.mean_error_last_10s = error_sum / error_count;
  result.matched_per_scan = static_cast<double>(matched) / scans;
  return result;
}

}  // namespace

TEST(FeatureEkfFilter, ConvergesFromAnOffsetPoseDespiteOdometryDrift) {
  FeatureEkfConfig config;
  config.initial_pose = Eigen::Vector3d(6.0 + 0.3, 1.5 - 0.25, 0.08);
  config.initial_stddev = Eigen::Vector3d(0.4, 0.4, 0.15);
  FeatureEkfFilter filter(config, test::map_from_walls(kBuilding));
  const RunResult r = drive(filter, 40.0, 1);
  EXPECT_GT(r.dead_reckoning_error, 0.5);
  EXPECT_LT(r.final_error, 0.05);
  EXPECT_LT(r.mean_error_last_10s, 0.05);
  EXPECT_LT(r.final_heading_error, 0.02);
  EXPECT_GT(r.matched_per_scan, 3.0);
  // The filter trusts itself no more than its errors allow: 3 sigma covers the final error.
  const Eigen::Matrix3d P = filter.covariance();
  EXPECT_LT(r.final_error, 3.0 * std::sqrt(P(0, 0) + P(1, 1)) + 0.01);
}

TEST(FeatureEkfFilter, EachFeatureKindAloneCorrectsThePose) {
  for (const char* kind : {"lines", "points"}) {
    FeatureEkfConfig config;
    config.initial_pose = Eigen::Vector3d(6.0 + 0.15, 1.5 + 0.1, -0.03);
    config.initial_stddev = Eigen::Vector3d(0.3, 0.3, 0.1);
    config.use_lines = std::string(kind) == "lines";
    config.use_corners = config.use_edges = !config.use_lines;
    FeatureEkfFilter filter(config, test::map_from_walls(kBuilding));
    const RunResult r = drive(filter, 30.0, 2);
    EXPECT_LT(r.mean_error_last_10s, 0.1) << kind;
    EXPECT_LT(r.mean_error_last_10s, 0.3 * r.dead_reckoning_error) << kind;
  }
}

TEST(FeatureEkfFilter, WithoutScansTheCovarianceGrowsWithTheMotion) {
  FeatureEkfFilter filter(FeatureEkfConfig{}, test::map_from_walls(kBuilding));
  filter.set_pose({1.0, 1.0, 0.0}, Eigen::Matrix3d::Identity() * 1e-4);
  const double before = filter.covariance().trace();
  Pose2 odometry(0, 0, 0), truth(1.0, 1.0, 0.0);
  EXPECT_FALSE(filter.apply_odometry(odometry, 0));
  const Pose2 step(0.05, 0.0, 0.01);
  odometry = odometry * step;
  truth = truth * step;
  EXPECT_TRUE(filter.apply_odometry(odometry, 50'000'000));
  const double after_short = filter.covariance().trace();
  for (int k = 2; k < 40; ++k) {
    odometry = odometry * step;
    truth = truth * step;
    filter.apply_odometry(odometry, k * 50'000'000LL);
  }
  EXPECT_GT(after_short, before);
  EXPECT_GT(filter.covariance().trace(), after_short);
  // Eq. 1 turns before it drives, so each step leaves the chord by up to d * gamma / 2 sideways:
  // 39 steps * 0.05 m * 0.005 rad ~ 1 cm, plus the heading it turns it into.
  EXPECT_LT((filter.pose().head<2>() - truth.vector().head<2>()).norm(), 0.03);
  EXPECT_NEAR(filter.pose().z(), truth.theta, 1e-9);
  // A gap beyond max_odometry_gap restarts odometry instead of predicting across it.
  const Eigen::Vector3d pose = filter.pose();
  EXPECT_FALSE(filter.apply_odometry(Pose2(10, 0, 0), 40 * 50'000'000LL + 5'000'000'000LL));
  EXPECT_EQ(filter.pose(), pose);
}

namespace {

// One lap of the corridor world's centre line (config/maps/corridor.yaml): straight at 1 m/s,
// turning on the spot at 0.8 rad/s in the corners. Odometry at 50 Hz reads 0.5 % long and its
// heading drifts 1 deg per metre driven (random walk); scans at 25 Hz, laser 0.2 m ahead.
struct CorridorLap {
  double rmse = 0.0, max_error = 0.0, mean_heading_error = 0.0, dead_reckoning_error = 0.0;
  int scans = 0;
};

CorridorLap drive_corridor_lap(FeatureEkfFilter& filter, const Pose2& start, uint64_t seed) {
  const FeatureMap2D& map = filter.map();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  test::ScanGeometry laser;
  laser.sensor_in_base = Pose2(0.2, 0.0, 0.0);
  const double dt = 0.02, speed = 1.0, turn_rate = 0.8;
  const double heading_drift_per_step = (M_PI / 180.0) * std::sqrt(speed * dt);
  // Legs: drive to the next corner of the loop, then turn left by 90 deg.
  const std::vector<Eigen::Vector2d> corners = {{39, 1}, {39, 19}, {1, 19}, {1, 1}};
  Pose2 truth = start, odometry;
  int64_t stamp = 0;
  int step = 0;
  double squared_sum = 0.0, heading_sum = 0.0;
  CorridorLap lap;
  filter.apply_odometry(odometry, stamp);
  const auto advance = [&](const Pose2& true_step) {
    truth = truth * true_step;
    const Pose2 measured_step(true_step.x * 1.005, true_step.y,
                              true_step.theta + heading_drift_per_step * unit(rng) * (true_step.x > 0 ? 1.0 : 0.0));
    odometry = odometry * measured_step;
    stamp += 20'000'000;
    filter.apply_odometry(odometry, stamp);
    if (++step % 2 == 0) {
      filter.update(test::ray_cast_scan(map.lines, truth, laser, &rng));
      const double error = (filter.pose().head<2>() - truth.vector().head<2>()).norm();
      if (step * dt > 2.0) {  // after the first 2 s
        squared_sum += error * error;
        heading_sum += std::abs(normalize_angle(filter.pose().z() - truth.theta));
        lap.max_error = std::max(lap.max_error, error);
        ++lap.scans;
      }
    }
  };
  for (const Eigen::Vector2d& corner : corners) {
    while ((corner - Eigen::Vector2d(truth.x, truth.y)).norm() > speed * dt) advance(Pose2(speed * dt, 0.0, 0.0));
    const double target = normalize_angle(truth.theta + M_PI / 2);
    while (std::abs(normalize_angle(target - truth.theta)) > turn_rate * dt) advance(Pose2(0.0, 0.0, turn_rate * dt));
    truth.theta = target;
  }
  const Pose2 dead_reckoning = start * odometry;
  lap.dead_reckoning_error = std::hypot(dead_reckoning.x - truth.x, dead_reckoning.y - truth.y);
  lap.rmse = std::sqrt(squared_sum / lap.scans);
  lap.mean_heading_error = heading_sum / lap.scans;
  return lap;
}

}  // namespace

TEST(FeatureEkfFilter, LapOfTheCorridorWorldStaysWithinFiveCentimetres) {
  const FeatureMap2D map = load_feature_map(test::source_dir() + "/config/maps/corridor.yaml", 100000);
  const Pose2 start(1.0, 1.0, 0.0);
  FeatureEkfConfig config;
  config.initial_pose = Eigen::Vector3d(start.x + 0.3, start.y - 0.2, 0.05);
  config.initial_stddev = Eigen::Vector3d(0.5, 0.5, 0.1);
  FeatureEkfFilter filter(config, map);
  const CorridorLap lap = drive_corridor_lap(filter, start, 7);
  std::cout << "corridor lap: scans " << lap.scans << ", rmse " << lap.rmse << " m, max " << lap.max_error
            << " m, mean heading error " << lap.mean_heading_error * 180.0 / M_PI << " deg, dead reckoning "
            << lap.dead_reckoning_error << " m\n";
  EXPECT_GT(lap.dead_reckoning_error, 0.3);
  EXPECT_LT(lap.rmse, 0.05);
  EXPECT_LT(lap.max_error, 0.3);
}

// Stamps reach the filter in order (the session sees to it); a repeated odometry stamp is a step
// of no time and predicts nothing.
TEST(FeatureEkfFilter, ARepeatedOdometryStampPredictsNothing) {
  FeatureEkfFilter filter(FeatureEkfConfig{}, test::map_from_walls(kBuilding));
  EXPECT_FALSE(filter.apply_odometry(Pose2(0.0, 0.0, 0.0), 1'000'000'000));
  EXPECT_TRUE(filter.apply_odometry(Pose2(0.02, 0.0, 0.0), 1'020'000'000));
  const Eigen::Matrix3d P = filter.covariance();
  const Eigen::Vector3d x = filter.pose();
  EXPECT_FALSE(filter.apply_odometry(Pose2(0.04, 0.0, 0.0), 1'020'000'000));
  EXPECT_EQ(filter.covariance(), P);
  EXPECT_EQ(filter.pose(), x);
}
