// The particle filter of the paper (section 3) on identical ceiling landmarks, plus what it
// leaves out: an adaptive particle count (KLD sampling, Fox 2003), global localization without
// an initial pose and recovery from kidnapping (augmented MCL, Probabilistic Robotics Table 8.3)
// with new particles drawn from the detections themselves (sensor-based proposal). Resampling,
// KLD, w_slow/w_fast and the cluster estimate are the sdk's particle-filter core
// (locd/sdk/particle_filter.hpp); the measurement model and the proposal are this filter's.
//
//   predict(u)          Table 2 on every particle
//   correct(detections) Table 1 per particle and detection (most likely of the N landmarks
//                       nearest to where the particle puts the detection), eq. 7-9 weights,
//                       then low-variance resampling when the effective sample size drops
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include "locd/ceiling_pf/config.hpp"
#include "locd/ceiling_pf/landmark_map.hpp"
#include "locd/ceiling_pf/velocity_motion_model.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sdk/particle_filter.hpp"

namespace locd::ceiling_pf {

using Particle = PoseParticle;

// A detection as the filter sees it: the ceiling point in base_link, and its range and bearing.
struct Detection {
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  double range = 0.0;
  double bearing = 0.0;
  static Detection from_point(const Eigen::Vector2d& p);
};

struct Association {
  int landmark = -1;          // map index, -1 = none (outlier term won)
  double normalized_error2 = 0.0;  // (dr/sr)^2 + (db/sb)^2 of the chosen landmark
  int candidates = 0;
};

struct CorrectionReport {
  size_t detections = 0;
  double effective_sample_size = 0.0;
  bool resampled = false;
  size_t injected = 0;
  double injection_probability = 0.0;
  double mean_likelihood = 0.0;  // mean share of detections explained (fit in [0, 1]), this frame
  bool global_start = false;     // the set was drawn from this frame's detections
  std::vector<Association> associations;  // of the best particle, one per detection
};

// Pose, covariance (x, y, yaw) and the weight inside the cluster around the mode.
using FilterEstimate = ParticleCluster;

class CeilingParticleFilter {
 public:
  CeilingParticleFilter(const ParticleFilterConfig& config, std::shared_ptr<const NearestLandmarkIndex> index,
                        const VelocityMotionModel& motion);

  // Gaussian cloud around a known pose (the paper's start); `particles` of them.
  void set_pose(const Pose2& mean, const Eigen::Matrix3d& covariance);
  // Unknown start: the next frame with detections draws the set from the detections.
  void set_unknown();
  bool initialized() const { return !particles_.empty(); }

  void predict(const VelocityCommand& u);
  CorrectionReport correct(const std::vector<Detection>& detections);

  // Log-likelihood of one particle for a frame (eq. 7 with the outlier term, each detection's
  // factor divided by its peak value), the chosen landmark per detection when associations is
  // non-null, and the mean per-detection fit in [0, 1] when explained is non-null.
  double log_likelihood(const Pose2& pose, const std::vector<Detection>& detections,
                        std::vector<Association>* associations = nullptr, double* explained = nullptr) const;

  std::optional<FilterEstimate> estimate() const;
  const std::vector<Particle>& particles() const { return particles_; }
  void set_particles(std::vector<Particle> particles);  // weights normalised here
  const ParticleFilterConfig& config() const { return config_; }
  double slow_average() const { return recovery_.slow(); }
  double fast_average() const { return recovery_.fast(); }

  // Poses drawn from the detections (pairs of detections matched to mapped landmark pairs of
  // the same distance; a single detection: a random landmark and heading).
  std::vector<Pose2> sample_from_detections(const std::vector<Detection>& detections, size_t count);
  size_t landmark_pairs() const { return pair_distance_.size(); }

 private:
  void resample(const std::vector<Detection>& detections, CorrectionReport& report);

  ParticleFilterConfig config_;
  std::shared_ptr<const NearestLandmarkIndex> index_;
  VelocityMotionModel motion_;
  std::vector<Particle> particles_;
  std::vector<bool> just_injected_;  // drawn from detections at the last resampling
  std::mt19937_64 rng_;
  KldResampling kld_;
  PoseBinCounter bins_;
  AugmentedMclRecovery recovery_;
  std::optional<Pose2> mode_;  // last mode, carried through predictions
  bool localized_ = false;     // one cluster has held half the weight since the last (re)start
  // Ordered landmark pairs (i, j) sorted by distance, for the detection proposal.
  std::vector<double> pair_distance_;
  std::vector<std::pair<int, int>> pairs_;
  double max_pair_distance_ = 0.0;
};

}  // namespace locd::ceiling_pf
