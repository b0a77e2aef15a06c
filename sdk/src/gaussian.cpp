#include "locd/sdk/gaussian.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace locd {

// Numerical Recipes 6.2: series for x < a + 1, continued fraction otherwise.
double regularized_gamma_p(double a, double x) {
  if (x <= 0.0) return 0.0;
  const double log_prefactor = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1.0) {
    double term = 1.0 / a, sum = term, ap = a;
    for (int n = 0; n < 1000; ++n) {
      ap += 1.0;
      term *= x / ap;
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return sum * std::exp(log_prefactor);
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return 1.0 - std::exp(log_prefactor) * h;
}

double chi_square_cdf(double x, int dof) { return regularized_gamma_p(0.5 * dof, 0.5 * x); }

double chi_square_quantile(double probability, int dof) {
  if (!(probability > 0.0 && probability < 1.0) || dof < 1) {
    throw std::invalid_argument("chi_square_quantile: probability must be in (0, 1), dof >= 1");
  }
  double lo = 0.0, hi = std::max(1.0, 2.0 * dof);
  while (chi_square_cdf(hi, dof) < probability) hi *= 2.0;
  for (int i = 0; i < 200 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (chi_square_cdf(mid, dof) < probability ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

ChiSquareGate::ChiSquareGate(double probability) : probability_(probability) {
  thresholds_[0] = 0.0;
  for (int dof = 1; dof <= 6; ++dof) thresholds_[dof] = chi_square_quantile(probability, dof);
}

double ChiSquareGate::threshold(int dof) const {
  return dof >= 1 && dof <= 6 ? thresholds_[dof] : chi_square_quantile(probability_, dof);
}

GaussianSampler::GaussianSampler(Eigen::VectorXd mean, const Eigen::MatrixXd& covariance)
    : mean_(std::move(mean)) {
  Eigen::LLT<Eigen::MatrixXd> llt(covariance);
  if (llt.info() != Eigen::Success) throw std::invalid_argument("covariance is not positive definite");
  L_ = llt.matrixL();
}

Eigen::VectorXd GaussianSampler::sample(std::mt19937_64& rng) const {
  Eigen::VectorXd z(mean_.size());
  for (Eigen::Index i = 0; i < z.size(); ++i) z[i] = normal_(rng);
  return mean_ + L_ * z;
}

double normal_pdf(double error, double sigma) {
  return std::exp(-0.5 * error * error / (sigma * sigma)) / (std::sqrt(2.0 * M_PI) * sigma);
}

}  // namespace locd
