// A planar laser scanner: beams cast exactly against the world's walls from the sensor's
// mount pose, each range plus zero-mean Gaussian noise; beams that hit nothing within
// range_max are "no return" (+inf).
#pragma once

#include <memory>

#include "locd/sim/sensor_model.hpp"
#include "locd/sim/world.hpp"

namespace locd::sim {

struct LaserScannerConfig {
  double rate_hz = 25.0;
  int beams = 361;
  double fov_deg = 180.0;
  double range_min = 0.05;
  double range_max = 30.0;
  double range_noise_stddev = 0.01;
  Pose2 mount{0.2, 0.0, 0.0};  // sensor in base_link
  std::string frame_id = "laser";

  static LaserScannerConfig from_params(const Params& params);
};

class LaserScannerModel : public SensorModel {
 public:
  LaserScannerModel(const LaserScannerConfig& config, std::shared_ptr<const RangeWorld> world);
  const std::string& name() const override { return name_; }
  double rate_hz() const override { return config_.rate_hz; }
  Measurement measure(const TruthSample& truth, int64_t stamp_ns, std::mt19937_64& rng) override;

  LaserScan scan(const Pose2& robot_pose, int64_t stamp_ns, std::mt19937_64& rng) const;
  const LaserScannerConfig& config() const { return config_; }

 private:
  std::string name_ = "laser";
  LaserScannerConfig config_;
  std::shared_ptr<const RangeWorld> world_;
};

}  // namespace locd::sim
