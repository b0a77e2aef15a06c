#include "locd/sdk/particle_filter.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "locd/sdk/gaussian.hpp"

namespace locd {

void normalize_weights(std::vector<PoseParticle>& particles) {
  double sum = 0.0;
  for (const PoseParticle& p : particles) sum += p.weight;
  const bool usable = sum > 0.0 && std::isfinite(sum);
  const double uniform = particles.empty() ? 0.0 : 1.0 / static_cast<double>(particles.size());
  for (PoseParticle& p : particles) p.weight = usable ? p.weight / sum : uniform;
}

double effective_sample_size(const std::vector<PoseParticle>& particles) {
  std::vector<double> weights(particles.size());
  for (size_t i = 0; i < particles.size(); ++i) weights[i] = particles[i].weight;
  return effective_sample_size(weights);
}

size_t kld_sample_bound(size_t k, double epsilon, double quantile) {
  if (k <= 1) return 0;
  // Upper standard normal quantile z_{1-delta} from the chi-square(1) quantile; Wilson-Hilferty.
  const double z = std::sqrt(chi_square_quantile(2.0 * quantile - 1.0, 1));
  const double a = 2.0 / (9.0 * static_cast<double>(k - 1));
  const double b = 1.0 - a + std::sqrt(a) * z;
  return static_cast<size_t>(std::ceil(static_cast<double>(k - 1) / (2.0 * epsilon) * b * b * b));
}

PoseBinCounter::PoseBinCounter(const Eigen::Vector3d& bin_size) : bin_size_(bin_size) {}

size_t PoseBinCounter::count(const std::vector<PoseParticle>& particles) {
  constexpr uint64_t kEmpty = ~uint64_t{0};  // a key uses 63 bits, never all ones
  size_t capacity = 16;
  while (capacity < 2 * particles.size()) capacity *= 2;
  if (table_.capacity() > 4 * capacity) std::vector<uint64_t>().swap(table_);  // the set shrank: give memory back
  table_.assign(capacity, kEmpty);
  const size_t mask = capacity - 1;
  int shift = 64;
  for (size_t c = capacity; c > 1; c >>= 1) --shift;
  const Eigen::Vector3d inverse = bin_size_.cwiseInverse();
  size_t occupied = 0;
  for (const PoseParticle& p : particles) {
    const auto ix = static_cast<int64_t>(std::floor(p.pose.x * inverse.x()));
    const auto iy = static_cast<int64_t>(std::floor(p.pose.y * inverse.y()));
    const auto it = static_cast<int64_t>(std::floor(p.pose.theta * inverse.z()));
    const uint64_t key = (static_cast<uint64_t>(ix & 0x1FFFFF) << 42) | (static_cast<uint64_t>(iy & 0x1FFFFF) << 21) |
                         static_cast<uint64_t>(it & 0x1FFFFF);
    size_t slot = static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> shift) & mask;
    while (table_[slot] != kEmpty && table_[slot] != key) slot = (slot + 1) & mask;
    if (table_[slot] == kEmpty) {
      table_[slot] = key;
      ++occupied;
    }
  }
  return occupied;
}

size_t kld_resample(std::vector<PoseParticle>& particles, const KldResampling& config, double injection_probability,
                    const PoseProposal& propose, PoseBinCounter& bins, std::mt19937_64& rng) {
  std::vector<double> weights(particles.size());
  for (size_t m = 0; m < particles.size(); ++m) weights[m] = particles[m].weight;
  size_t count = config.enabled ? std::clamp(particles.size(), config.min_particles, config.max_particles)
                                : config.particles;
  std::vector<PoseParticle> next;
  size_t injected = 0;
  for (int round = 0; round < 8; ++round) {
    injected = propose ? static_cast<size_t>(std::lround(injection_probability * static_cast<double>(count))) : 0;
    const std::vector<size_t> picks = low_variance_resample(weights, count - injected, rng);
    next.clear();
    next.reserve(count);
    const double w = 1.0 / static_cast<double>(count);
    for (size_t i : picks) next.push_back({particles[i].pose, w});
    const size_t drawn = next.size();
    if (injected > 0) propose(injected, next);
    for (size_t m = drawn; m < next.size(); ++m) next[m].weight = w;
    if (!config.enabled) break;
    const size_t needed =
        std::clamp(kld_sample_bound(bins.count(next), config.epsilon, config.quantile), config.min_particles,
                   config.max_particles);
    if (needed == count) break;
    if (needed < count) {
      if (round > 0 && needed > count / 2) break;  // grown already: keep, no oscillation
      count = needed;
      continue;
    }
    count = std::min(config.max_particles, std::max(needed, static_cast<size_t>(1.5 * static_cast<double>(count))));
    if (count == next.size()) break;
  }
  particles = std::move(next);
  normalize_weights(particles);
  return injected;
}

AugmentedMclRecovery::AugmentedMclRecovery(double alpha_slow, double alpha_fast)
    : alpha_slow_(alpha_slow), alpha_fast_(alpha_fast) {}

void AugmentedMclRecovery::update(double average_likelihood) {
  if (!(slow_ > 0.0) || !(fast_ > 0.0)) {
    slow_ = fast_ = average_likelihood;
    return;
  }
  slow_ += alpha_slow_ * (average_likelihood - slow_);
  fast_ += alpha_fast_ * (average_likelihood - fast_);
}

double AugmentedMclRecovery::injection_probability(double min_probability) const {
  const double ratio = slow_ > 0.0 ? fast_ / slow_ : 1.0;
  const double p = 1.0 - ratio;
  return p > 0.0 && p >= min_probability ? p : 0.0;
}

ParticleCluster cluster_around(const std::vector<PoseParticle>& particles, const Pose2& seed, double radius) {
  ParticleCluster e;
  const double r2 = radius * radius;
  Eigen::Vector2d centre(seed.x, seed.y);
  double mass = 0.0;
  for (int iteration = 0; iteration < 4; ++iteration) {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    mass = 0.0;
    for (const PoseParticle& p : particles) {
      const Eigen::Vector2d q(p.pose.x, p.pose.y);
      if ((q - centre).squaredNorm() > r2) continue;
      sum += p.weight * q;
      mass += p.weight;
    }
    if (!(mass > 0.0)) break;
    const Eigen::Vector2d next = sum / mass;
    const bool settled = (next - centre).squaredNorm() < 1e-8;
    centre = next;
    if (settled) break;
  }
  double sc = 0.0, ss = 0.0;
  for (const PoseParticle& p : particles) {
    if ((Eigen::Vector2d(p.pose.x, p.pose.y) - centre).squaredNorm() > r2) continue;
    sc += p.weight * std::cos(p.pose.theta);
    ss += p.weight * std::sin(p.pose.theta);
  }
  e.pose = Pose2(centre.x(), centre.y(), mass > 0.0 ? std::atan2(ss, sc) : seed.theta);
  e.mass = mass;
  const bool whole = mass < 0.5;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double total = 0.0;
  for (const PoseParticle& p : particles) {
    const Eigen::Vector3d d(p.pose.x - centre.x(), p.pose.y - centre.y(), normalize_angle(p.pose.theta - e.pose.theta));
    if (!whole && d.head<2>().squaredNorm() > r2) continue;
    cov += p.weight * d * d.transpose();
    total += p.weight;
  }
  if (total > 0.0) cov /= total;
  e.covariance = cov + Eigen::Matrix3d::Identity() * 1e-9;
  return e;
}

std::vector<Particle2D> diagnostic_particles(const std::vector<PoseParticle>& particles, size_t shown) {
  std::vector<Particle2D> out;
  if (shown == 0 || particles.empty()) return out;
  const size_t stride = (particles.size() + shown - 1) / shown;
  out.reserve(particles.size() / stride + 1);
  for (size_t i = 0; i < particles.size(); i += stride) {
    const PoseParticle& p = particles[i];
    out.push_back({p.pose.x, p.pose.y, p.pose.theta, p.weight * static_cast<double>(stride)});
  }
  return out;
}

Eigen::Matrix3d floor_covariance(Eigen::Matrix3d covariance, double position_stddev, double heading_stddev) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(covariance.topLeftCorner<2, 2>());
  for (int i = 0; i < 2; ++i) {
    const double missing = position_stddev * position_stddev - eigen.eigenvalues()(i);
    if (missing > 0.0) {
      covariance.topLeftCorner<2, 2>() += missing * eigen.eigenvectors().col(i) * eigen.eigenvectors().col(i).transpose();
    }
  }
  covariance(2, 2) = std::max(covariance(2, 2), heading_stddev * heading_stddev);
  return covariance;
}

ParticleCluster main_cluster(const std::vector<PoseParticle>& particles, double radius,
                             const std::optional<Pose2>& previous_mode) {
  if (particles.empty()) return {};
  const auto best = std::max_element(particles.begin(), particles.end(),
                                     [](const PoseParticle& a, const PoseParticle& b) { return a.weight < b.weight; });
  ParticleCluster around_best = cluster_around(particles, best->pose, radius);
  if (previous_mode) {
    ParticleCluster around_previous = cluster_around(particles, *previous_mode, radius);
    if (around_previous.mass >= around_best.mass) return around_previous;
  }
  return around_best;
}

}  // namespace locd
