// The velocity motion model of the paper's Table 2 (Thrun et al., Probabilistic Robotics,
// Table 5.3): noisy v, omega and a final rotation gamma, each with standard deviation
// alpha_i v^2 + alpha_j omega^2 (the paper's "Sample(b): normal with standard deviation b").
#pragma once

#include <array>
#include <random>

#include "locd/ceiling_pf/config.hpp"
#include "locd/sdk/geometry.hpp"

namespace locd::ceiling_pf {

struct VelocityCommand {
  double linear = 0.0;   // v, m/s
  double angular = 0.0;  // omega, rad/s
  double dt = 0.0;       // s
};

// The (v, omega) that carries `from` to `to` along one circular arc in dt (the exact inverse of
// the noise-free model for the arc's end point and heading).
VelocityCommand velocity_between(const Pose2& from, const Pose2& to, double dt);

class VelocityMotionModel {
 public:
  explicit VelocityMotionModel(MotionNoise alpha = kPaperMotionNoise);

  // Noise-free arc (gamma = extra rotation rate).
  static Pose2 move(const Pose2& pose, double linear, double angular, double gamma, double dt);
  // Table 2: one sample of the next pose.
  Pose2 sample(const Pose2& pose, const VelocityCommand& u, std::mt19937_64& rng) const;
  const std::array<double, 6>& alpha() const { return alpha_; }

 private:
  std::array<double, 6> alpha_;
  mutable std::normal_distribution<double> normal_{0.0, 1.0};
};

}  // namespace locd::ceiling_pf
