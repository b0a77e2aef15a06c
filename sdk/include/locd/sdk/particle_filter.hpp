// The particle-filter pieces every particle-filter plugin composes (ceiling_pf, grid_mcl), each a
// named step of Monte Carlo localization (Thrun, Burgard, Fox, Probabilistic Robotics, ch. 4 and
// 8; Fox 2003 for KLD sampling):
//
//   PoseParticle, normalize_weights, effective_sample_size   the weighted set of planar poses
//   kld_sample_bound, PoseBinCounter                          Fox 2003, eq. 12 and its bins
//   kld_resample                                              low-variance resampling to a KLD count,
//                                                             with a share of injected poses
//   AugmentedMclRecovery                                      Table 8.3: w_slow, w_fast, injection
//   cluster_around, main_cluster                              the estimate: the weighted mean and
//                                                             covariance of the set near its mode
//
// A plugin keeps its own measurement model, motion model and proposal for injected poses.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <optional>
#include <random>
#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/resampling.hpp"
#include "locd/sdk/types.hpp"

namespace locd {

struct PoseParticle {
  Pose2 pose;
  double weight = 0.0;
};

// Scales the weights to sum 1; a set whose weights sum to zero (or not to a finite number)
// becomes uniform.
void normalize_weights(std::vector<PoseParticle>& particles);
// 1 / sum(w_i^2) of the normalised weights.
double effective_sample_size(const std::vector<PoseParticle>& particles);

// KLD sampling (Fox 2003, eq. 12): the number of particles for which, with probability
// `quantile` (1 - delta), the KL divergence between the sample-based and the true posterior
// stays below epsilon, when the particles occupy k bins. 0 for k <= 1.
size_t kld_sample_bound(size_t occupied_bins, double epsilon, double quantile);

// Counts the (x, y, yaw) bins a set occupies, with an open-addressing hash table whose buffer is
// reused between calls (a set of 100k particles is counted in about a millisecond).
class PoseBinCounter {
 public:
  explicit PoseBinCounter(const Eigen::Vector3d& bin_size);
  size_t count(const std::vector<PoseParticle>& particles);
  const Eigen::Vector3d& bin_size() const { return bin_size_; }
  size_t memory_bytes() const { return table_.capacity() * sizeof(uint64_t); }

 private:
  Eigen::Vector3d bin_size_;
  std::vector<uint64_t> table_;
};

struct KldResampling {
  bool enabled = true;         // false: always `particles`
  size_t particles = 500;      // the fixed count without KLD
  size_t min_particles = 100;
  size_t max_particles = 20000;
  double epsilon = 0.05;
  double quantile = 0.99;      // 1 - delta
  Eigen::Vector3d bin{0.2, 0.2, 0.1};  // m, m, rad
};

// Appends `count` new poses (weight set by the caller) for augmented MCL's injection.
using PoseProposal = std::function<void(size_t count, std::vector<PoseParticle>& out)>;

// Low-variance resampling (Table 4.4) of `particles` into a new set of equal weights, of which a
// share `injection_probability` comes from `propose` (Table 8.3, line 14) and is placed last.
// With KLD the count starts at the current size (within [min, max]) and is grown or shrunk until
// it is the bound for the bins the new set occupies (injected poses included); at most 8 rounds,
// and once grown it does not shrink below half again. Returns how many poses were injected.
size_t kld_resample(std::vector<PoseParticle>& particles, const KldResampling& config, double injection_probability,
                    const PoseProposal& propose, PoseBinCounter& bins, std::mt19937_64& rng);

// Augmented MCL (Table 8.3, lines 10-11): short- and long-term averages of the measurement
// likelihood; the first average starts both.
class AugmentedMclRecovery {
 public:
  AugmentedMclRecovery(double alpha_slow = 0.001, double alpha_fast = 0.1);
  void reset() { slow_ = fast_ = 0.0; }
  void update(double average_likelihood);
  double slow() const { return slow_; }
  double fast() const { return fast_; }
  // max(0, 1 - w_fast / w_slow), and 0 while it is below min_probability.
  double injection_probability(double min_probability = 0.0) const;

 private:
  double alpha_slow_, alpha_fast_;
  double slow_ = 0.0, fast_ = 0.0;
};

struct ParticleCluster {
  Pose2 pose;                                                // weighted mean (circular for yaw)
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  // x, y, yaw
  double mass = 0.0;                                         // weight within the radius
};

// Mean shift from `seed` over the particles within `radius` (position), at most 4 steps; the
// covariance is the cluster's, or the whole set's about the cluster mean when the cluster holds
// less than half the weight (the ambiguity stays visible). Weights are taken as normalised.
ParticleCluster cluster_around(const std::vector<PoseParticle>& particles, const Pose2& seed, double radius);
// The heavier of the clusters around the previous mode and around the heaviest particle (a lone
// particle that fits one measurement well does not move the estimate). Empty set: mass 0.
ParticleCluster main_cluster(const std::vector<PoseParticle>& particles, double radius,
                             const std::optional<Pose2>& previous_mode);

// At most `shown` particles for the diagnostics topic: every k-th, its weight times k so the
// weights still sum to the set's. None when `shown` is 0.
std::vector<Particle2D> diagnostic_particles(const std::vector<PoseParticle>& particles, size_t shown);

// A cluster's (x, y, yaw) covariance raised to at least `position_stddev` along every direction
// of the plane and `heading_stddev` in yaw, directions already wider unchanged. Once KLD sampling
// has shrunk a converged set, the particles' spread falls below the error they carry (sample
// impoverishment, and a map no finer than its cells); the published covariance must not.
Eigen::Matrix3d floor_covariance(Eigen::Matrix3d covariance, double position_stddev, double heading_stddev);

}  // namespace locd
