// A planar laser scanner: beams cast exactly against the world's walls from the sensor's
// mount pose, each range plus zero-mean Gaussian noise; beams that hit nothing within
// range_max are "no return" (+inf).
//
// Dropouts (optional, `dropouts: {rate: 0.05, burst_beams: 3, kinds: [nan, zero, max_range, inf]}`):
// readings a real scanner gives instead of a range (REP 117: NaN an invalid reading, +inf no return;
// drivers also give 0 or range_max). Along each scan a burst starts, lasts a geometric number of
// beams with mean burst_beams, and takes one of `kinds` (equally likely); the start probability is
// set so that `rate` is the long-run fraction of beams dropped.
#pragma once

#include <memory>
#include <vector>

#include "locd/sim/sensor_model.hpp"
#include "locd/sim/world.hpp"

namespace locd::sim {

enum class Dropout { kNan, kZero, kMaxRange, kInfinity };

struct DropoutConfig {
  double rate = 0.0;         // fraction of beams
  double burst_beams = 1.0;  // mean beams per burst
  std::vector<Dropout> kinds{Dropout::kNan};
};

struct LaserScannerConfig {
  double rate_hz = 25.0;
  int beams = 361;
  double fov_deg = 180.0;
  double range_min = 0.05;
  double range_max = 30.0;
  double range_noise_stddev = 0.01;
  Pose2 mount{0.2, 0.0, 0.0};  // sensor in base_link
  std::string frame_id = "laser";
  DropoutConfig dropouts;

  static LaserScannerConfig from_params(const Params& params);
};

class LaserScannerModel : public SensorModel {
 public:
  LaserScannerModel(const LaserScannerConfig& config, std::shared_ptr<const RangeWorld> world);
  const std::string& name() const override { return name_; }
  double rate_hz() const override { return config_.rate_hz; }
  Measurement measure(const TruthSample& truth, int64_t stamp_ns, std::mt19937_64& rng) override;

  // t: s since the start, for worlds with moving things.
  LaserScan scan(const Pose2& robot_pose, int64_t stamp_ns, std::mt19937_64& rng, double t = 0.0) const;
  const LaserScannerConfig& config() const { return config_; }

 private:
  void apply_dropouts(LaserScan& scan, std::mt19937_64& rng) const;
  std::string name_ = "laser";
  LaserScannerConfig config_;
  std::shared_ptr<const RangeWorld> world_;
};

}  // namespace locd::sim
