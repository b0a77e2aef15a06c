// Wheel odometry with drift. Between two truth samples the body-frame motion is a translation
// d (direction phi) and a rotation dtheta; odometry reports
//   d'      = d (1 + translation_scale_error) + n_d,   n_d ~ N(0, translation_fraction^2 * d * 1 m)
//   dtheta' = dtheta (1 + rotation_scale_error) + n_r,
//             n_r ~ N(0, rotation_per_metre^2 * d * 1 m + rotation_fraction^2 * |dtheta| * 1 rad)
// and integrates them in the odom frame. Variances grow with distance and angle travelled, not
// with the rate: after 1 m straight the position stddev is translation_fraction * 1 m and the
// heading stddev rotation_per_metre * 1 m, whatever the odometry rate.
#pragma once

#include "locd/sim/sensor_model.hpp"

namespace locd::sim {

struct OdometryDrift {
  double translation_fraction = 0.02;    // stddev per sqrt(metre), as a fraction of 1 m
  double rotation_deg_per_metre = 1.0;   // heading stddev per sqrt(metre) driven, in degrees
  double rotation_fraction = 0.02;       // heading stddev per sqrt(radian) turned, as a fraction
  double translation_scale_error = 0.005;
  double rotation_scale_error = 0.0;
};

struct OdometryConfig {
  double rate_hz = 50.0;
  OdometryDrift drift;
  std::string frame_id = "odom";

  static OdometryConfig from_params(const Params& params);
};

struct OdometryIncrement {
  double distance = 0.0;   // signed, along direction
  double direction = 0.0;  // of the translation, body frame
  double rotation = 0.0;
};

class OdometryModel : public SensorModel {
 public:
  explicit OdometryModel(const OdometryConfig& config);
  const std::string& name() const override { return name_; }
  double rate_hz() const override { return config_.rate_hz; }
  Measurement measure(const TruthSample& truth, int64_t stamp_ns, std::mt19937_64& rng) override;

  // The true body-frame increment between two poses, and the reported (noisy) one.
  static OdometryIncrement increment_between(const Pose2& from, const Pose2& to);
  OdometryIncrement noisy(const OdometryIncrement& truth, std::mt19937_64& rng) const;
  const OdometryConfig& config() const { return config_; }

 private:
  std::string name_ = "odometry";
  OdometryConfig config_;
  bool started_ = false;
  Pose2 last_truth_;
  Pose2 odom_pose_;
  double last_t_ = 0.0;
};

}  // namespace locd::sim
