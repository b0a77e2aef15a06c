// Gaussians, Mahalanobis distance and chi-square gates.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <random>

namespace locd {

// Squared Mahalanobis distance v^T S^-1 v, through a Cholesky factorisation (no inverse).
// Returns +inf when S is not positive definite.
template <typename Vector, typename Matrix>
double mahalanobis2(const Vector& v, const Matrix& S) {
  Eigen::LLT<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic>> llt(S);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  const Eigen::VectorXd w = llt.matrixL().solve(Eigen::VectorXd(v));
  return w.squaredNorm();
}

// Chi-square CDF with `dof` degrees of freedom (Boost.Math).
double chi_square_cdf(double x, int dof);
// Chi-square quantile: the x with chi_square_cdf(x, dof) = probability, 0 < probability < 1
// (Boost.Math); std::invalid_argument otherwise.
double chi_square_quantile(double probability, int dof);

// Gate on an innovation: passes when its squared Mahalanobis distance is below the chi-square
// quantile of `probability` for the innovation's dimension.
class ChiSquareGate {
 public:
  explicit ChiSquareGate(double probability = 0.99);
  double probability() const { return probability_; }
  double threshold(int dof) const;  // cached for dof 1..6
  bool accepts(double mahalanobis2, int dof) const { return mahalanobis2 <= threshold(dof); }

 private:
  double probability_;
  double thresholds_[7];
};

// Samples from N(mean, covariance) with a fixed seedable engine.
class GaussianSampler {
 public:
  GaussianSampler(Eigen::VectorXd mean, const Eigen::MatrixXd& covariance);
  Eigen::VectorXd sample(std::mt19937_64& rng) const;
  const Eigen::VectorXd& mean() const { return mean_; }

 private:
  Eigen::VectorXd mean_;
  Eigen::MatrixXd L_;
  mutable std::normal_distribution<double> normal_{0.0, 1.0};
};

// Standard normal deviates by Marsaglia & Tsang's ziggurat ("The Ziggurat Method for Generating
// Random Variables", 2000; 128 layers): one 64-bit draw and a table lookup for about 98 % of the
// samples, several times faster than std::normal_distribution's polar method, for samplers that
// draw millions per second (a particle filter's motion model).
class ZigguratNormal {
 public:
  ZigguratNormal();
  double operator()(std::mt19937_64& rng) const;

 private:
  double x_[129];  // layer edges, x_[0] = v / f(r) (the base strip with its tail), x_[1] = r, x_[128] = 0
  double f_[129];  // exp(-x^2 / 2) at the edges
};

// Gaussian density exp(-0.5 * e^2 / sigma^2) / (sqrt(2 pi) sigma).
double normal_pdf(double error, double sigma);

}  // namespace locd
