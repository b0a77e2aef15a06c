#include "locd/sim/laser_scanner.hpp"

#include <cmath>
#include <limits>

namespace locd::sim {

LaserScannerConfig LaserScannerConfig::from_params(const Params& p) {
  p.expect_only({"rate_hz", "beams", "fov_deg", "range_min", "range_max", "range_noise_stddev", "mount", "frame_id"});
  LaserScannerConfig c;
  c.rate_hz = p.number("rate_hz", c.rate_hz, Range{0.0, 1000.0, true, false});
  c.beams = static_cast<int>(p.integer("beams", c.beams, 2, 8192));
  c.fov_deg = p.number("fov_deg", c.fov_deg, Range{0.0, 360.0, true, false});
  c.range_min = p.number("range_min", c.range_min, Range::non_negative());
  c.range_max = p.number("range_max", c.range_max, Range{0.0, 1000.0, true, false});
  if (c.range_max <= c.range_min) p.fail("range_max", "must be greater than range_min");
  c.range_noise_stddev = p.number("range_noise_stddev", c.range_noise_stddev, Range{0.0, 1.0});
  const auto mount = p.numbers("mount", {c.mount.x, c.mount.y, c.mount.theta}, 3, Range{-10.0, 10.0});
  c.mount = {mount[0], mount[1], mount[2]};
  c.frame_id = p.text("frame_id", c.frame_id);
  return c;
}

LaserScannerModel::LaserScannerModel(const LaserScannerConfig& config, std::shared_ptr<const RangeWorld> world)
    : config_(config), world_(std::move(world)) {}

Measurement LaserScannerModel::measure(const TruthSample& truth, int64_t stamp_ns, std::mt19937_64& rng) {
  return scan(truth.pose, stamp_ns, rng);
}

LaserScan LaserScannerModel::scan(const Pose2& robot_pose, int64_t stamp_ns, std::mt19937_64& rng) const {
  LaserScan s;
  s.header.stamp_ns = stamp_ns;
  s.header.frame_id = config_.frame_id;
  s.sensor_pose = config_.mount.to_isometry();
  const double fov = config_.fov_deg * M_PI / 180.0;
  const double increment = fov / (config_.beams - (config_.fov_deg >= 360.0 ? 0 : 1));
  s.angle_min = static_cast<float>(-fov / 2.0);
  s.angle_increment = static_cast<float>(increment);
  s.range_min = static_cast<float>(config_.range_min);
  s.range_max = static_cast<float>(config_.range_max);
  s.ranges.resize(config_.beams);
  const Pose2 sensor = robot_pose * config_.mount;
  std::normal_distribution<double> noise(0.0, config_.range_noise_stddev);
  for (int i = 0; i < config_.beams; ++i) {
    const double angle = sensor.theta + s.angle(i);
    const auto range = world_->cast({sensor.x, sensor.y}, angle, config_.range_max);
    double r = std::numeric_limits<double>::infinity();
    if (range) {
      r = *range + (config_.range_noise_stddev > 0 ? noise(rng) : 0.0);
      if (r > config_.range_max || r < config_.range_min) r = std::numeric_limits<double>::infinity();
    }
    s.ranges[i] = static_cast<float>(r);
  }
  return s;
}

}  // namespace locd::sim
