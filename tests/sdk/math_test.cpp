#include <gtest/gtest.h>

#include <numeric>

#include "locd/sdk/gaussian.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sdk/grid.hpp"
#include "locd/sdk/resampling.hpp"

using namespace locd;

TEST(Geometry, NormalizeAngle) {
  EXPECT_NEAR(normalize_angle(3 * M_PI), -M_PI, 1e-12);
  EXPECT_NEAR(normalize_angle(-0.5), -0.5, 1e-12);
  EXPECT_NEAR(normalize_angle(2 * M_PI + 0.25), 0.25, 1e-12);
}

TEST(Geometry, Pose2ComposeInverseAndIsometryAgree) {
  const Pose2 a(1.0, 2.0, 0.7), b(-0.3, 0.5, -1.9);
  const Pose2 ab = a * b;
  const Eigen::Isometry3d T = a.to_isometry() * b.to_isometry();
  const Pose2 from3d = Pose2::from_isometry(T);
  EXPECT_NEAR(ab.x, from3d.x, 1e-12);
  EXPECT_NEAR(ab.y, from3d.y, 1e-12);
  EXPECT_NEAR(ab.theta, from3d.theta, 1e-12);
  const Pose2 identity = a * a.inverse();
  EXPECT_NEAR(identity.x, 0, 1e-12);
  EXPECT_NEAR(identity.y, 0, 1e-12);
  EXPECT_NEAR(identity.theta, 0, 1e-12);
  const Eigen::Vector2d p = a.transform({1, 0});
  EXPECT_NEAR(p.x(), 1 + std::cos(0.7), 1e-12);
  EXPECT_NEAR(p.y(), 2 + std::sin(0.7), 1e-12);
}

TEST(Geometry, RollPitchYawRoundTrip) {
  const Eigen::Vector3d rpy(0.1, -0.2, 2.5);
  const Eigen::Vector3d back = roll_pitch_yaw(quaternion_from_rpy(rpy[0], rpy[1], rpy[2]).toRotationMatrix());
  EXPECT_TRUE(back.isApprox(rpy, 1e-12)) << back.transpose();
}

TEST(ChiSquare, QuantilesMatchTables) {
  // Standard table values.
  EXPECT_NEAR(chi_square_quantile(0.95, 1), 3.841459, 1e-5);
  EXPECT_NEAR(chi_square_quantile(0.99, 2), 9.210340, 1e-5);
  EXPECT_NEAR(chi_square_quantile(0.95, 3), 7.814728, 1e-5);
  EXPECT_NEAR(chi_square_quantile(0.999, 6), 22.457744, 1e-4);
  // The non-unique landmark paper's gamma = 11.9 is the 99.74 % gate for 2 dof.
  EXPECT_NEAR(chi_square_cdf(11.9, 2), 1 - std::exp(-11.9 / 2), 1e-12);
  for (int dof = 1; dof <= 8; ++dof) {
    EXPECT_NEAR(chi_square_cdf(chi_square_quantile(0.9, dof), dof), 0.9, 1e-10);
  }
  EXPECT_THROW(chi_square_quantile(1.0, 2), std::invalid_argument);
}

TEST(ChiSquare, GateAcceptsInsideRejectsOutside) {
  const ChiSquareGate gate(0.99);
  EXPECT_TRUE(gate.accepts(9.2, 2));
  EXPECT_FALSE(gate.accepts(9.25, 2));
  EXPECT_NEAR(gate.threshold(2), 9.210340, 1e-5);
}

TEST(Gaussian, MahalanobisMatchesDirectInverse) {
  Eigen::Matrix3d S;
  S << 2.0, 0.3, 0.1, 0.3, 1.0, -0.2, 0.1, -0.2, 0.5;
  const Eigen::Vector3d v(0.4, -1.2, 0.7);
  EXPECT_NEAR(mahalanobis2(v, S), v.dot(S.inverse() * v), 1e-12);
  Eigen::Matrix2d singular = Eigen::Matrix2d::Zero();
  EXPECT_TRUE(std::isinf(mahalanobis2(Eigen::Vector2d(1, 1), singular)));
}

TEST(Gaussian, SamplerHasItsMoments) {
  Eigen::Vector2d mean(1.0, -2.0);
  Eigen::Matrix2d cov;
  cov << 0.5, 0.2, 0.2, 0.3;
  const GaussianSampler sampler(mean, cov);
  std::mt19937_64 rng(7);
  const int n = 200000;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  Eigen::Matrix2d outer = Eigen::Matrix2d::Zero();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d s = sampler.sample(rng);
    sum += s;
    outer += (s - mean) * (s - mean).transpose();
  }
  EXPECT_TRUE((sum / n).isApprox(mean, 1e-2)) << (sum / n).transpose();
  EXPECT_LT(((outer / n) - cov).cwiseAbs().maxCoeff(), 0.01);
  EXPECT_NEAR(normal_pdf(0.0, 2.0), 1.0 / (std::sqrt(2 * M_PI) * 2.0), 1e-15);
}

TEST(Resampling, EffectiveSampleSize) {
  EXPECT_NEAR(effective_sample_size({1, 1, 1, 1}), 4.0, 1e-12);
  EXPECT_NEAR(effective_sample_size({0, 0, 5, 0}), 1.0, 1e-12);
  EXPECT_EQ(effective_sample_size({0, 0}), 0.0);
}

TEST(Resampling, LowVarianceIsUnbiased) {
  // The resampled set's mean of a quantity equals the weighted mean, in expectation, and each
  // particle is drawn floor or ceil of count * w_i times (low variance).
  const std::vector<double> values{0.0, 1.0, 5.0, 10.0};
  const std::vector<double> weights{0.1, 0.2, 0.3, 0.4};
  const double weighted_mean = 0.0 * 0.1 + 1.0 * 0.2 + 5.0 * 0.3 + 10.0 * 0.4;
  std::mt19937_64 rng(3);
  const size_t count = 100;
  double mean_of_means = 0.0;
  const int trials = 2000;
  for (int t = 0; t < trials; ++t) {
    const auto idx = low_variance_resample(weights, count, rng);
    ASSERT_EQ(idx.size(), count);
    std::vector<int> hits(weights.size(), 0);
    double s = 0.0;
    for (size_t i : idx) {
      ++hits[i];
      s += values[i];
    }
    for (size_t i = 0; i < weights.size(); ++i) {
      EXPECT_LE(std::abs(hits[i] - count * weights[i]), 1.0 + 1e-9);
    }
    mean_of_means += s / count;
  }
  EXPECT_NEAR(mean_of_means / trials, weighted_mean, 0.01);
}

TEST(Resampling, ZeroWeightsResampleUniformly) {
  std::mt19937_64 rng(1);
  const auto idx = low_variance_resample({0, 0, 0, 0}, 8, rng);
  std::vector<int> hits(4, 0);
  for (size_t i : idx) ++hits[i];
  for (int h : hits) EXPECT_EQ(h, 2);
}

TEST(Grid, IndexAndCenterRoundTrip) {
  GridGeometry g{0.5, {-1.0, 2.0}, 10, 4};
  int row = -1, col = -1;
  ASSERT_TRUE(g.index_of({0.3, 3.2}, row, col));
  EXPECT_EQ(col, 2);
  EXPECT_EQ(row, 2);
  const Eigen::Vector2d c = g.center_of(row, col);
  EXPECT_NEAR(c.x(), 0.25, 1e-12);
  EXPECT_NEAR(c.y(), 3.25, 1e-12);
  EXPECT_FALSE(g.index_of({-1.01, 2.5}, row, col));
  EXPECT_FALSE(g.index_of({0.0, 4.0}, row, col));
  Grid<float> grid(g, 0.0f);
  grid.at(3, 9) = 2.0f;
  const GridLayer layer = to_layer(grid, "belief");
  EXPECT_EQ(layer.cells[3 * 10 + 9], 2.0f);
}
