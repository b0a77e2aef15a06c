// The sdk's particle-filter core against direct formulas: the KLD bound against the chi-square
// quantile, the bin counter against a std::set, resampling's weighted mean and injection, the
// recovery averages by hand, the cluster's moments against a direct weighted mean and covariance.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <tuple>

#include "locd/sdk/gaussian.hpp"
#include "locd/sdk/particle_filter.hpp"

namespace {

using namespace locd;

TEST(ParticleFilterCore, KldBoundFollowsTheChiSquareQuantile) {
  EXPECT_EQ(kld_sample_bound(0, 0.05, 0.99), 0u);
  EXPECT_EQ(kld_sample_bound(1, 0.05, 0.99), 0u);
  // Fox 2003, eq. 12 approximates n = chi2_{k-1, 1-delta} / (2 epsilon) (Wilson-Hilferty).
  for (size_t k : {2, 5, 11, 101, 1001, 20001}) {
    const double direct = chi_square_quantile(0.99, static_cast<int>(k - 1)) / (2.0 * 0.05);
    EXPECT_NEAR(static_cast<double>(kld_sample_bound(k, 0.05, 0.99)), direct, 0.02 * direct + 1.0) << k;
  }
  EXPECT_LT(kld_sample_bound(50, 0.05, 0.99), kld_sample_bound(51, 0.05, 0.99));
  EXPECT_GT(kld_sample_bound(50, 0.01, 0.99), kld_sample_bound(50, 0.05, 0.99));
}

TEST(ParticleFilterCore, BinCounterAgreesWithASet) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> position(0.0, 3.0), heading(0.0, 2.0);
  const Eigen::Vector3d bin(0.25, 0.5, 0.1);
  PoseBinCounter counter(bin);
  for (size_t n : {0, 1, 7, 1000, 50000}) {
    std::vector<PoseParticle> particles(n);
    std::set<std::tuple<long, long, long>> direct;
    for (PoseParticle& p : particles) {
      p.pose = Pose2(position(rng), position(rng), normalize_angle(heading(rng)));
      direct.insert({static_cast<long>(std::floor(p.pose.x / bin.x())), static_cast<long>(std::floor(p.pose.y / bin.y())),
                     static_cast<long>(std::floor(p.pose.theta / bin.z()))});
    }
    EXPECT_EQ(counter.count(particles), direct.size()) << n;
  }
}

TEST(ParticleFilterCore, WeightsNormaliseAndEffectiveSampleSize) {
  std::vector<PoseParticle> set{{Pose2(), 2.0}, {Pose2(), 2.0}, {Pose2(), 0.0}, {Pose2(), 4.0}};
  normalize_weights(set);
  EXPECT_DOUBLE_EQ(set[3].weight, 0.5);
  EXPECT_NEAR(effective_sample_size(set), 1.0 / (0.25 * 0.25 * 2 + 0.5 * 0.5), 1e-12);
  std::vector<PoseParticle> zero(4);
  normalize_weights(zero);
  for (const PoseParticle& p : zero) EXPECT_DOUBLE_EQ(p.weight, 0.25);
}

std::vector<PoseParticle> skewed_set(size_t n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> x(-5, 5), w(0, 1);
  std::vector<PoseParticle> set(n);
  for (PoseParticle& p : set) {
    p.pose = Pose2(x(rng), 0.0, 0.0);
    p.weight = std::pow(w(rng), 4);
  }
  normalize_weights(set);
  return set;
}

TEST(ParticleFilterCore, ResamplingKeepsTheWeightedMean) {
  std::mt19937_64 rng(11);
  const std::vector<PoseParticle> set = skewed_set(200, rng);
  double weighted_mean = 0.0;
  for (const PoseParticle& p : set) weighted_mean += p.weight * p.pose.x;
  KldResampling fixed;
  fixed.enabled = false;
  fixed.particles = 200;
  PoseBinCounter bins(fixed.bin);
  const int repeats = 2000;
  double mean_of_means = 0.0, spread = 0.0;
  for (int r = 0; r < repeats; ++r) {
    std::vector<PoseParticle> next = set;
    EXPECT_EQ(kld_resample(next, fixed, 0.0, {}, bins, rng), 0u);
    ASSERT_EQ(next.size(), 200u);
    double m = 0.0;
    for (const PoseParticle& p : next) {
      EXPECT_NEAR(p.weight, 1.0 / 200.0, 1e-15);
      m += p.pose.x / 200.0;
    }
    mean_of_means += m / repeats;
    spread += (m - weighted_mean) * (m - weighted_mean);
  }
  const double standard_error = std::sqrt(spread / repeats / repeats);
  EXPECT_NEAR(mean_of_means, weighted_mean, 4.0 * standard_error + 1e-12);
  EXPECT_GT(standard_error, 0.0);
}

TEST(ParticleFilterCore, InjectedPosesComeLastInTheirShare) {
  std::mt19937_64 rng(3);
  std::vector<PoseParticle> set = skewed_set(400, rng);
  KldResampling fixed;
  fixed.enabled = false;
  fixed.particles = 400;
  PoseBinCounter bins(fixed.bin);
  const size_t injected = kld_resample(
      set, fixed, 0.25, [](size_t count, std::vector<PoseParticle>& out) {
        for (size_t i = 0; i < count; ++i) out.push_back({Pose2(100.0, 100.0, 0.0), 123.0});
      },
      bins, rng);
  EXPECT_EQ(injected, 100u);
  ASSERT_EQ(set.size(), 400u);
  for (size_t i = 0; i < set.size(); ++i) {
    EXPECT_EQ(set[i].pose.x == 100.0, i >= 300) << i;
    EXPECT_NEAR(set[i].weight, 1.0 / 400.0, 1e-15);
  }
}

TEST(ParticleFilterCore, KldShrinksAConcentratedSetAndGrowsASpreadOne) {
  std::mt19937_64 rng(8);
  KldResampling kld;
  kld.min_particles = 50;
  kld.max_particles = 5000;
  PoseBinCounter bins(kld.bin);
  // 2000 particles in one bin: the bound for one bin is 0, the count drops to the minimum.
  std::vector<PoseParticle> concentrated(2000, {Pose2(0.05, 0.05, 0.05), 1.0});
  normalize_weights(concentrated);
  kld_resample(concentrated, kld, 0.0, {}, bins, rng);
  EXPECT_EQ(concentrated.size(), 50u);
  // 100 particles spread over many bins: the set grows to the bound of the bins it occupies.
  std::uniform_real_distribution<double> x(-10, 10), yaw(-M_PI, M_PI);
  std::vector<PoseParticle> spread(100);
  for (PoseParticle& p : spread) p = {Pose2(x(rng), x(rng), yaw(rng)), 1.0};
  normalize_weights(spread);
  kld_resample(spread, kld, 0.0, {}, bins, rng);
  EXPECT_GT(spread.size(), 100u);
  EXPECT_LE(spread.size(), 5000u);
  const size_t bound = std::clamp<size_t>(kld_sample_bound(bins.count(spread), kld.epsilon, kld.quantile), 50, 5000);
  EXPECT_GE(spread.size(), bound / 2) << "within the rounds' tolerance of the bound";
}

TEST(ParticleFilterCore, RecoveryAveragesByHand) {
  AugmentedMclRecovery recovery(0.1, 0.5);
  EXPECT_EQ(recovery.injection_probability(), 0.0);
  recovery.update(1.0);
  EXPECT_DOUBLE_EQ(recovery.slow(), 1.0);
  EXPECT_DOUBLE_EQ(recovery.fast(), 1.0);
  recovery.update(0.2);  // slow: 1 + 0.1 (0.2 - 1) = 0.92, fast: 1 + 0.5 (0.2 - 1) = 0.6
  EXPECT_DOUBLE_EQ(recovery.slow(), 0.92);
  EXPECT_DOUBLE_EQ(recovery.fast(), 0.6);
  EXPECT_NEAR(recovery.injection_probability(), 1.0 - 0.6 / 0.92, 1e-15);
  EXPECT_EQ(recovery.injection_probability(0.5), 0.0) << "below the minimum: none";
  recovery.update(5.0);  // fast above slow: no injection
  EXPECT_GT(recovery.fast(), recovery.slow());
  EXPECT_EQ(recovery.injection_probability(), 0.0);
  recovery.reset();
  EXPECT_EQ(recovery.slow(), 0.0);
}

TEST(ParticleFilterCore, ClusterMomentsMatchTheDirectFormula) {
  std::mt19937_64 rng(21);
  std::normal_distribution<double> noise(0.0, 0.2), heading(0.0, 0.05);
  std::vector<PoseParticle> set;
  // 70 % of the weight near (1, 2) with yaw across +-pi, 30 % far away near (10, 10).
  for (int i = 0; i < 700; ++i) set.push_back({Pose2(1 + noise(rng), 2 + noise(rng), normalize_angle(M_PI + heading(rng))), 1.0});
  for (int i = 0; i < 300; ++i) set.push_back({Pose2(10 + noise(rng), 10 + noise(rng), 0.0), 1.0});
  normalize_weights(set);
  const ParticleCluster c = cluster_around(set, Pose2(1.5, 2.5, 0.0), 1.5);
  double mass = 0.0, sc = 0.0, ss = 0.0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const PoseParticle& p : set) {
    if (p.pose.x > 5) continue;
    mass += p.weight;
    mean += p.weight * Eigen::Vector2d(p.pose.x, p.pose.y);
    sc += p.weight * std::cos(p.pose.theta);
    ss += p.weight * std::sin(p.pose.theta);
  }
  mean /= mass;
  const double yaw = std::atan2(ss, sc);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const PoseParticle& p : set) {
    if (p.pose.x > 5) continue;
    const Eigen::Vector3d d(p.pose.x - mean.x(), p.pose.y - mean.y(), normalize_angle(p.pose.theta - yaw));
    cov += p.weight * d * d.transpose() / mass;
  }
  // Every particle of the first group lies within 1.5 m of its mean (1.5 m is 7.5 sigma).
  EXPECT_NEAR(c.mass, 0.7, 1e-12);
  EXPECT_NEAR(c.pose.x, mean.x(), 1e-9);
  EXPECT_NEAR(c.pose.y, mean.y(), 1e-9);
  EXPECT_NEAR(normalize_angle(c.pose.theta - yaw), 0.0, 1e-9);
  EXPECT_NEAR(std::abs(c.pose.theta), M_PI, 0.02) << "circular mean across +-pi";
  EXPECT_LT((c.covariance - cov).cwiseAbs().maxCoeff(), 1e-8);

  // The main cluster: the heavier of the previous mode's and the best particle's.
  set.back().weight *= 10.0;  // the best particle now lies in the lighter group
  normalize_weights(set);
  EXPECT_NEAR(main_cluster(set, 1.5, std::nullopt).pose.x, 10.0, 0.1);
  EXPECT_NEAR(main_cluster(set, 1.5, Pose2(1.0, 2.0, 0.0)).pose.x, 1.0, 0.1);
  // A cluster with less than half the weight reports the whole set's spread.
  const ParticleCluster light = cluster_around(set, Pose2(10.0, 10.0, 0.0), 1.5);
  EXPECT_LT(light.mass, 0.5);
  EXPECT_GT(light.covariance(0, 0), 10.0);
  EXPECT_EQ(main_cluster({}, 1.0, std::nullopt).mass, 0.0);
}

}  // namespace

namespace {

// The ziggurat's samples against the standard normal: moments and the CDF at fixed points.
TEST(ParticleFilterCore, CovarianceFloorRaisesOnlyTheNarrowDirections) {
  // A cluster 10 cm wide along 30 degrees and 2 mm across it, 0.001 rad in heading.
  const double a = 0.5236;
  Eigen::Matrix2d rotation;
  rotation << std::cos(a), -std::sin(a), std::sin(a), std::cos(a);
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  covariance.topLeftCorner<2, 2>() = rotation * Eigen::Vector2d(0.01, 4e-6).asDiagonal() * rotation.transpose();
  covariance(2, 2) = 1e-6;
  const Eigen::Matrix3d floored = floor_covariance(covariance, 0.02, 0.005);
  // Along the wide direction unchanged (0.1 m), across it raised to the floor (0.02 m).
  const Eigen::Vector2d along = rotation.col(0), across = rotation.col(1);
  EXPECT_NEAR(along.dot(floored.topLeftCorner<2, 2>() * along), 0.01, 1e-12);
  EXPECT_NEAR(across.dot(floored.topLeftCorner<2, 2>() * across), 4e-4, 1e-12);
  EXPECT_NEAR(along.dot(floored.topLeftCorner<2, 2>() * across), 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(floored(2, 2), 0.005 * 0.005);
  // A covariance already above the floor everywhere is returned as it is.
  const Eigen::Matrix3d wide = Eigen::Vector3d(0.01, 0.02, 0.01).asDiagonal();
  EXPECT_TRUE(floor_covariance(wide, 0.02, 0.005).isApprox(wide, 1e-15));
}

TEST(ZigguratNormal, MomentsAndDistributionOfTheStandardNormal) {
  const locd::ZigguratNormal normal;
  std::mt19937_64 rng(17);
  const int n = 2'000'000;
  double sum = 0.0, sum2 = 0.0, sum4 = 0.0;
  const double edges[] = {-3.5, -2.0, -1.0, -0.3, 0.0, 0.3, 1.0, 2.0, 3.5};
  std::vector<int> below(std::size(edges), 0);
  for (int i = 0; i < n; ++i) {
    const double x = normal(rng);
    sum += x;
    sum2 += x * x;
    sum4 += x * x * x * x;
    for (size_t k = 0; k < std::size(edges); ++k) below[k] += x < edges[k];
  }
  EXPECT_NEAR(sum / n, 0.0, 4.0 / std::sqrt(n));
  EXPECT_NEAR(sum2 / n, 1.0, 4.0 * std::sqrt(2.0 / n));
  EXPECT_NEAR(sum4 / n, 3.0, 4.0 * std::sqrt(96.0 / n));
  for (size_t k = 0; k < std::size(edges); ++k) {
    const double p = 0.5 * std::erfc(-edges[k] / std::sqrt(2.0));
    EXPECT_NEAR(static_cast<double>(below[k]) / n, p, 4.0 * std::sqrt(p * (1 - p) / n) + 1e-9) << edges[k];
  }
}

}  // namespace
