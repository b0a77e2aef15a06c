// Ray-cast 2D scans against wall segments, for feature_ekf tests and its benchmark.
#pragma once

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "locd/sdk/feature_map.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sdk/types.hpp"

namespace locd::test {

struct ScanGeometry {
  int beams = 361;
  double angle_min = -M_PI / 2;
  double angle_increment = M_PI / 360;  // 0.5 deg
  double range_min = 0.05;
  double range_max = 30.0;
  double range_stddev = 0.01;
  Pose2 sensor_in_base{0.1, 0.0, 0.0};
};

// Range along a ray from origin in direction angle to the nearest segment; +inf if none.
inline double cast_ray(const std::vector<LineFeature>& walls, const Eigen::Vector2d& origin, double angle) {
  const Eigen::Vector2d d(std::cos(angle), std::sin(angle));
  double best = std::numeric_limits<double>::infinity();
  for (const LineFeature& w : walls) {
    const Eigen::Vector2d e = w.b - w.a;
    const double denominator = d.x() * e.y() - d.y() * e.x();
    if (std::abs(denominator) < 1e-12) continue;
    const Eigen::Vector2d q = w.a - origin;
    const double t = (q.x() * e.y() - q.y() * e.x()) / denominator;   // along the ray
    const double s = (q.x() * d.y() - q.y() * d.x()) / denominator;   // along the wall
    if (t > 0.0 && s >= 0.0 && s <= 1.0 && t < best) best = t;
  }
  return best;
}

inline LaserScan ray_cast_scan(const std::vector<LineFeature>& walls, const Pose2& robot, const ScanGeometry& g,
                               std::mt19937_64* rng = nullptr) {
  LaserScan scan;
  scan.header.frame_id = "laser";
  scan.sensor_pose = g.sensor_in_base.to_isometry();
  scan.angle_min = static_cast<float>(g.angle_min);
  scan.angle_increment = static_cast<float>(g.angle_increment);
  scan.range_min = static_cast<float>(g.range_min);
  scan.range_max = static_cast<float>(g.range_max);
  const Pose2 sensor = robot * g.sensor_in_base;
  std::normal_distribution<double> noise(0.0, g.range_stddev);
  scan.ranges.resize(g.beams);
  for (int i = 0; i < g.beams; ++i) {
    double r = cast_ray(walls, {sensor.x, sensor.y}, sensor.theta + scan.angle(i));
    if (std::isfinite(r) && rng) r += noise(*rng);
    scan.ranges[i] = r <= g.range_max ? static_cast<float>(r) : std::numeric_limits<float>::infinity();
  }
  return scan;
}

// Walls from polylines, as FeatureMap2D lines (id "w<wall>l<segment>").
inline FeatureMap2D map_from_walls(const std::string& yaml_text) {
  return parse_feature_map(Params::parse(yaml_text, "test map"), 100000);
}

}  // namespace locd::test
