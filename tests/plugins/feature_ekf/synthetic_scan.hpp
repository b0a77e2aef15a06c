// 2D scans of wall maps for feature_ekf's tests: locsim's laser scanner (locd/sim/laser_scanner.hpp,
// the one 2D ray caster) with the tests' beam geometry, noise-free when no random engine is given.
#pragma once

#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "locd/sdk/feature_map.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sim/laser_scanner.hpp"

namespace locd::test {

struct ScanGeometry {
  int beams = 361;               // over 180 deg: 0.5 deg apart, from -90 deg
  double range_min = 0.05;
  double range_max = 30.0;
  double range_stddev = 0.01;
  Pose2 sensor_in_base{0.1, 0.0, 0.0};
};

inline LaserScan ray_cast_scan(const std::vector<LineFeature>& walls, const Pose2& robot, const ScanGeometry& g,
                               std::mt19937_64* rng = nullptr) {
  std::vector<sim::Segment> segments;
  for (const LineFeature& w : walls) segments.push_back({w.a, w.b});
  sim::LaserScannerConfig config;
  config.beams = g.beams;
  config.fov_deg = 180.0;
  config.range_min = g.range_min;
  config.range_max = g.range_max;
  config.range_noise_stddev = rng ? g.range_stddev : 0.0;
  config.mount = g.sensor_in_base;
  const sim::LaserScannerModel laser(config, std::make_shared<const sim::SegmentWorld>(std::move(segments)));
  std::mt19937_64 unused;
  return laser.scan(robot, 0, rng ? *rng : unused);
}

// Walls from polylines, as FeatureMap2D lines (id "w<wall>l<segment>").
inline FeatureMap2D map_from_walls(const std::string& yaml_text) {
  return parse_feature_map(Params::parse(yaml_text, "test map"), 100000);
}

}  // namespace locd::test
