// The local elevation map from tilted laser scans (eq. 1-5) and the simulator's ray casting.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "locd/emoi_markov/local_elevation_map.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sim_emoi_markov/four_positions.hpp"
#include "locd/sim_emoi_markov/synthetic_dsm.hpp"
#include "locd/sim_emoi_markov/tilting_laser.hpp"

namespace {

using namespace locd::emoi;
namespace sim = locd::sim::emoi;

TEST(LocalMap, TiltingLaserPoseMatchesEquationThree) {
  const double x_tilt = 0.2, z_tilt = 0.5, x_laser = 0.05, z_laser = 0.1;
  for (double tilt : {-0.1, 0.0, 0.3}) {
    const Eigen::Isometry3d T = tilting_laser_pose(x_tilt, z_tilt, x_laser, z_laser, tilt);
    for (double alpha : {-1.2, 0.0, 0.7}) {
      const double d = 12.5;
      const Eigen::Vector3d p = T * Eigen::Vector3d(d * std::cos(alpha), d * std::sin(alpha), 0.0);
      const double a = d * std::cos(alpha) + x_laser;  // eq. 3, element by element
      EXPECT_NEAR(p.x(), a * std::cos(tilt) + z_laser * std::sin(tilt) + x_tilt, 1e-12);
      EXPECT_NEAR(p.y(), d * std::sin(alpha), 1e-12);
      EXPECT_NEAR(p.z(), a * std::sin(-tilt) + z_laser * std::cos(tilt) + z_tilt, 1e-12);
    }
  }
}

TEST(LocalMap, RpyRotationIsEquationFourAndTheSdkConvention) {
  const double yaw = 0.7, pitch = -0.2, roll = 0.15;
  const Eigen::Matrix3d R = rpy_rotation(yaw, pitch, roll);
  const Eigen::Matrix3d expected = locd::isometry_from_xyz_rpy(0, 0, 0, roll, pitch, yaw).linear();
  EXPECT_LT((R - expected).norm(), 1e-12);
  EXPECT_LT((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
}

TEST(LocalMap, MaxHeightUpdateKeepsTheHighestReturn) {
  LocalMapConfig config;
  config.size_m = 10.0;
  LocalElevationMap map(config);
  map.follow({0.0, 0.0});
  EXPECT_TRUE(map.insert_point({1.05, 1.05, 2.0}, 0.0));
  EXPECT_TRUE(map.insert_point({1.05, 1.05, 1.0}, 0.0));   // lower: kept 2.0 (eq. 5)
  EXPECT_TRUE(map.insert_point({1.02, 1.08, 3.0}, 0.0));   // same cell, higher: 3.0
  EXPECT_FALSE(map.insert_point({40.0, 0.0, 1.0}, 0.0));   // outside the grid
  const auto observed = map.observed(0.0);
  const auto g = map.geometry();
  int row = 0, col = 0;
  ASSERT_TRUE(g.index_of({1.05, 1.05}, row, col));
  EXPECT_FLOAT_EQ(observed(row, col), 3.0f);
  EXPECT_EQ(map.observed_cells(0.0), 1u);
}

TEST(LocalMap, ForgetsCellsNotSeenWithinTheMemoryDistance) {
  LocalMapConfig config;
  config.size_m = 10.0;
  config.memory_distance_m = 5.0;
  LocalElevationMap map(config);
  map.follow({0.0, 0.0});
  map.insert_point({1.0, 1.0, 2.0}, 0.0);
  map.insert_point({-1.0, 1.0, 2.0}, 4.0);
  EXPECT_EQ(map.observed_cells(4.0), 2u);
  EXPECT_EQ(map.observed_cells(7.0), 1u);
  map.insert_point({1.0, 1.0, 0.5}, 7.0);  // stale cell: replaced, not maxed
  int row = 0, col = 0;
  ASSERT_TRUE(map.geometry().index_of({1.0, 1.0}, row, col));
  EXPECT_FLOAT_EQ(map.observed(7.0)(row, col), 0.5f);
}

TEST(LocalMap, ScrollingKeepsWhatOverlaps) {
  LocalMapConfig config;
  config.size_m = 20.0;
  LocalElevationMap map(config);
  map.follow({0.0, 0.0});
  map.insert_point({3.0, 0.0, 1.5}, 0.0);
  map.follow({8.0, 0.0});  // beyond the central half: recentred
  EXPECT_NEAR(map.geometry().origin.x(), -2.0, 0.11);
  int row = 0, col = 0;
  ASSERT_TRUE(map.geometry().index_of({3.0, 0.0}, row, col));
  EXPECT_FLOAT_EQ(map.observed(0.0)(row, col), 1.5f);
}

// A flat world with one box: scans from a tilting laser rebuild the heights they hit.
TEST(LocalMap, SyntheticScansRebuildTheSurface) {
  ElevationMap world;
  world.geometry.resolution = 0.1;
  world.geometry.width = world.geometry.height = 400;  // 40 x 40 m
  world.elevation = cv::Mat_<float>(400, 400, 0.0f);
  world.elevation(cv::Rect(150, 180, 30, 40)).setTo(0.6f);  // box at x 15-18, y 18-22, below the laser

  sim::TiltingLaserConfig laser;
  laser.range_stddev_m = 0.0;
  LocalMapConfig config;
  config.size_m = 40.0;
  LocalElevationMap map(config);
  std::mt19937_64 rng(1);
  const Eigen::Isometry3d robot = locd::isometry_from_xyz_rpy(10.0, 20.0, 0.4, 0.0, 0.0, 0.0);
  map.follow({10.0, 20.0});
  size_t inserted = 0;
  for (int k = 0; k < 20; ++k) {
    const double t = k * 0.1;
    const locd::LaserScan scan = sim::simulate_scan(laser, world, robot, t, static_cast<int64_t>(t * 1e9), rng);
    inserted += map.insert_scan(scan, robot, 0.0).inserted;
  }
  EXPECT_GT(inserted, 1000u);
  const auto observed = map.observed(0.0);
  const auto g = map.geometry();
  size_t ground = 0, box = 0, wrong = 0;
  for (int r = 0; r < observed.rows; ++r) {
    for (int c = 0; c < observed.cols; ++c) {
      const float e = observed(r, c);
      if (!std::isfinite(e)) continue;
      const Eigen::Vector2d p = g.center_of(r, c);
      int wr = 0, wc = 0;
      ASSERT_TRUE(world.geometry.index_of(p, wr, wc));
      const float truth = world.elevation(wr, wc);
      // A return on a box face lands in the cell in front of or at the face: compare with the
      // highest truth within one cell.
      float near = truth;
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc)
          if (world.geometry.contains(wr + dr, wc + dc)) near = std::max(near, world.elevation(wr + dr, wc + dc));
      if (std::abs(e - truth) < 0.05) {
        (truth > 0.3f ? box : ground)++;
      } else if (e > near + 0.05 || e < -0.05) {
        ++wrong;
      }
    }
  }
  EXPECT_GT(ground, 500u);
  EXPECT_GT(box, 5u);
  EXPECT_EQ(wrong, 0u);
}

TEST(LocalMap, NanAndNoReturnBeamsAreCountedNotInserted) {
  LocalMapConfig config;
  config.size_m = 40.0;
  LocalElevationMap map(config);
  map.follow({0.0, 0.0});
  locd::LaserScan scan;
  scan.angle_min = -0.1f;
  scan.angle_increment = 0.1f;
  scan.range_min = 0.5f;
  scan.range_max = 80.0f;
  scan.ranges = {std::numeric_limits<float>::quiet_NaN(), 0.0f, 5.0f};
  scan.sensor_pose = tilting_laser_pose(0.2, 0.5, 0.05, 0.1, 0.2);
  const auto stats = map.insert_scan(scan, Eigen::Isometry3d::Identity(), 0.0);
  EXPECT_EQ(stats.invalid, 2u);
  EXPECT_EQ(stats.inserted, 1u);
}

TEST(Simulator, HeightfieldRayHitsGroundAndWalls) {
  ElevationMap world;
  world.geometry.resolution = 0.1;
  world.geometry.width = world.geometry.height = 200;
  world.elevation = cv::Mat_<float>(200, 200, 0.0f);
  world.elevation(cv::Rect(150, 0, 5, 200)).setTo(2.0f);  // wall at x = 15 m
  // Down at 45 deg from 1 m: hits the ground 1 m ahead, at range sqrt(2).
  const auto ground = sim::cast_heightfield(world, {5.0, 10.0, 1.0}, Eigen::Vector3d(1, 0, -1).normalized(), 80.0);
  ASSERT_TRUE(ground);
  EXPECT_NEAR(*ground, std::sqrt(2.0), 1e-9);
  const auto wall = sim::cast_heightfield(world, {5.0, 10.0, 1.0}, Eigen::Vector3d(1, 0, 0), 80.0);
  ASSERT_TRUE(wall);
  EXPECT_NEAR(*wall, 10.0, 1e-9);
  EXPECT_FALSE(sim::cast_heightfield(world, {5.0, 10.0, 1.0}, Eigen::Vector3d(-1, 0, 0), 80.0));  // leaves the map
  EXPECT_FALSE(sim::cast_heightfield(world, {5.0, 10.0, 1.0}, Eigen::Vector3d(1, 0, 0), 5.0));    // out of range
}

TEST(Simulator, WorldsAreDeterministicFromTheSeed) {
  sim::SyntheticDsmConfig config;
  config.size_x_m = config.size_y_m = 40.0;
  config.resolution_m = 0.2;
  config.buildings = 3;
  config.walls = 3;
  config.trees = 5;
  const auto a = sim::generate_world(config, 7), b = sim::generate_world(config, 7), c = sim::generate_world(config, 8);
  EXPECT_EQ(cv::norm(a.surface.elevation, b.surface.elevation, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a.surface.elevation, c.surface.elevation, cv::NORM_INF), 0.1);
  // Objects stand on the ground: the surface is never below the terrain.
  cv::Mat_<float> difference = a.surface.elevation - a.terrain.elevation;
  double low = 0.0;
  cv::minMaxLoc(difference, &low);
  EXPECT_GE(low, 0.0);
}

// robot.random_path: a new path per seed, the same for the same seed; legs of leg_m, turns within
// max_turn_deg, every waypoint margin_m inside the world; given with `path` it is refused by name.
TEST(Simulator, RandomPathsPerSeedStayInsideAndTurnWithinTheLimit) {
  const std::filesystem::path directory = std::filesystem::temp_directory_path() / "emoi_random_path_test";
  std::filesystem::create_directories(directory);
  std::ofstream(directory / "plugin.yaml") << "plugin: emoi_markov\nparams:\n  map: x.tif\n";
  const std::string common =
      "kind: emoi_four_positions\nworld: {size_m: [150, 120]}\nsensors: {laser: {}, odometry: {}, imu: {}}\n"
      "localizer: {config_file: plugin.yaml}\n";
  std::ofstream(directory / "random.yaml")
      << common << "robot: {random_path: {legs: 6, leg_m: 12, max_turn_deg: 45, margin_m: 20}}\n";
  std::ofstream(directory / "both.yaml")
      << common << "robot: {path: [[10, 10], [20, 10]], random_path: {legs: 2}}\n";
  const sim::FourPositionsScenario scenario = sim::load_four_positions(directory / "random.yaml");
  const auto a = sim::path_for_seed(scenario, 3), b = sim::path_for_seed(scenario, 3), c = sim::path_for_seed(scenario, 4);
  ASSERT_EQ(a.size(), 7u);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  for (const auto& path : {a, c}) {
    for (size_t i = 0; i < path.size(); ++i) {
      EXPECT_GE(path[i].x(), 20.0 - 1e-9);
      EXPECT_LE(path[i].x(), 130.0 + 1e-9);
      EXPECT_GE(path[i].y(), 20.0 - 1e-9);
      EXPECT_LE(path[i].y(), 100.0 + 1e-9);
      if (i > 0) {
        EXPECT_NEAR((path[i] - path[i - 1]).norm(), 12.0, 1e-9);
      }
      if (i > 1) {
        const Eigen::Vector2d u = path[i - 1] - path[i - 2], v = path[i] - path[i - 1];
        EXPECT_LE(std::acos(std::clamp(u.dot(v) / (u.norm() * v.norm()), -1.0, 1.0)), M_PI / 4 + 1e-9);
      }
    }
  }
  EXPECT_EQ(sim::build_run(scenario, 3).path, a);
  try {
    sim::load_four_positions(directory / "both.yaml");
    FAIL() << "no error";
  } catch (const locd::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("random_path"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(directory);
}

}  // namespace
