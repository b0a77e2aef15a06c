#include "locd/sdk/gaussian.hpp"

#include <boost/math/distributions/chi_squared.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace locd {

double chi_square_cdf(double x, int dof) {
  if (!(x > 0.0)) return 0.0;
  return boost::math::cdf(boost::math::chi_squared_distribution<double>(dof), x);
}

double chi_square_quantile(double probability, int dof) {
  if (!(probability > 0.0 && probability < 1.0) || dof < 1) {
    throw std::invalid_argument("chi_square_quantile: probability must be in (0, 1), dof >= 1");
  }
  return boost::math::quantile(boost::math::chi_squared_distribution<double>(dof), probability);
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
