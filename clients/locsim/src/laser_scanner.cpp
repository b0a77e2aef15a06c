#include "locd/sim/laser_scanner.hpp"

#include <cmath>
#include <limits>

#include "locd/sdk/text.hpp"

namespace locd::sim {

LaserScannerConfig LaserScannerConfig::from_params(const Params& p) {
  p.expect_only({"rate_hz", "beams", "fov_deg", "range_min", "range_max", "range_noise_stddev", "mount", "frame_id",
                 "dropouts"});
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
  if (p.has("dropouts")) {
    const Params d = p.child("dropouts");
    d.expect_only({"rate", "burst_beams", "kinds"});
    c.dropouts.rate = d.number("rate", 0.0, Range{0.0, 1.0, false, true});
    c.dropouts.burst_beams = d.number("burst_beams", 1.0, Range::closed(1.0, 1000.0));
    if (c.dropouts.rate > c.dropouts.burst_beams / (c.dropouts.burst_beams + 1.0)) {
      d.fail("rate", "= " + std::to_string(c.dropouts.rate) + " cannot be reached with burst_beams = " +
                         std::to_string(c.dropouts.burst_beams) + " (bursts apart by at least one beam); allowed: up to " +
                         "burst_beams / (burst_beams + 1)");
    }
    if (d.has("kinds")) {
      const YAML::Node list = d.node()["kinds"];
      if (!list.IsSequence() || list.size() == 0) {
        d.fail("kinds", "is not a non-empty list; allowed: some of nan, zero, max_range, inf");
      }
      c.dropouts.kinds.clear();
      for (size_t i = 0; i < list.size(); ++i) {
        const std::string kind = list[i].IsScalar() ? list[i].Scalar() : "(not a name)";
        if (kind == "nan") {
          c.dropouts.kinds.push_back(Dropout::kNan);
        } else if (kind == "zero") {
          c.dropouts.kinds.push_back(Dropout::kZero);
        } else if (kind == "max_range") {
          c.dropouts.kinds.push_back(Dropout::kMaxRange);
        } else if (kind == "inf") {
          c.dropouts.kinds.push_back(Dropout::kInfinity);
        } else {
          d.fail("kinds", "entry " + std::to_string(i) + " = '" + escaped(kind, 40) +
                              "' is not a dropout; allowed: nan, zero, max_range, inf");
        }
      }
    }
  }
  return c;
}

void LaserScannerModel::apply_dropouts(LaserScan& s, std::mt19937_64& rng) const {
  const DropoutConfig& d = config_.dropouts;
  if (d.rate <= 0.0) return;
  // A two-state chain along the beams: from one beam to the next a burst ends with probability
  // 1 / L (mean length L) and one starts with probability q; its stationary share of dropped
  // beams q / (q + 1 / L) is the rate.
  const double end = 1.0 / d.burst_beams;
  const double start = std::min(1.0, d.rate * end / (1.0 - d.rate));
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::uniform_int_distribution<size_t> kind_of(0, d.kinds.size() - 1);
  bool in_burst = uniform(rng) < d.rate;  // the first beam from the stationary share
  Dropout kind = d.kinds[kind_of(rng)];
  for (size_t i = 0; i < s.ranges.size(); ++i) {
    if (i > 0) {
      if (in_burst) {
        in_burst = uniform(rng) >= end;
      } else if (uniform(rng) < start) {
        in_burst = true;
        kind = d.kinds[kind_of(rng)];
      }
    }
    float& r = s.ranges[i];
    if (in_burst) {
      switch (kind) {
        case Dropout::kNan: r = std::numeric_limits<float>::quiet_NaN(); break;
        case Dropout::kZero: r = 0.0f; break;
        case Dropout::kMaxRange: r = s.range_max; break;
        case Dropout::kInfinity: r = std::numeric_limits<float>::infinity(); break;
      }
    }
  }
}

LaserScannerModel::LaserScannerModel(const LaserScannerConfig& config, std::shared_ptr<const RangeWorld> world)
    : config_(config), world_(std::move(world)) {}

Measurement LaserScannerModel::measure(const TruthSample& truth, int64_t stamp_ns, std::mt19937_64& rng) {
  return scan(truth.pose, stamp_ns, rng, truth.t);
}

LaserScan LaserScannerModel::scan(const Pose2& robot_pose, int64_t stamp_ns, std::mt19937_64& rng, double t) const {
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
    const auto range = world_->cast_at(t, {sensor.x, sensor.y}, angle, config_.range_max);
    double r = std::numeric_limits<double>::infinity();
    if (range) {
      r = *range + (config_.range_noise_stddev > 0 ? noise(rng) : 0.0);
      if (r > config_.range_max || r < config_.range_min) r = std::numeric_limits<double>::infinity();
    }
    s.ranges[i] = static_cast<float>(r);
  }
  apply_dropouts(s, rng);
  return s;
}

}  // namespace locd::sim
