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

namespace {
constexpr double kZigguratR = 3.442619855899;         // where the tail starts
constexpr double kZigguratArea = 9.91256303526217e-3;  // area of each layer
double unnormalised_pdf(double x) { return std::exp(-0.5 * x * x); }
// (0, 1), 53 random bits.
double open_unit(uint64_t bits) { return (static_cast<double>(bits >> 11) + 0.5) * 0x1.0p-53; }
}  // namespace

ZigguratNormal::ZigguratNormal() {
  x_[0] = kZigguratArea / unnormalised_pdf(kZigguratR);
  x_[1] = kZigguratR;
  for (int i = 1; i < 127; ++i) x_[i + 1] = std::sqrt(-2.0 * std::log(kZigguratArea / x_[i] + unnormalised_pdf(x_[i])));
  x_[128] = 0.0;
  for (int i = 0; i <= 128; ++i) f_[i] = unnormalised_pdf(x_[i]);
}

double ZigguratNormal::operator()(std::mt19937_64& rng) const {
  for (;;) {
    const uint64_t bits = rng();
    const int i = static_cast<int>(bits & 127);
    const double u = 2.0 * open_unit(bits) - 1.0;  // bits 11..63, independent of the layer's
    const double x = u * x_[i];
    if (std::abs(x) < x_[i + 1]) return x;  // inside the layer's rectangle under the curve
    if (i == 0) {
      // The tail beyond r (Marsaglia 1964).
      double a = 0.0, b = 0.0;
      do {
        a = -std::log(open_unit(rng())) / kZigguratR;
        b = -std::log(open_unit(rng()));
      } while (b + b < a * a);
      return u > 0.0 ? kZigguratR + a : -(kZigguratR + a);
    }
    // The wedge between the curve and the layer's rectangle.
    if (f_[i + 1] + open_unit(rng()) * (f_[i] - f_[i + 1]) < unnormalised_pdf(x)) return x;
  }
}

double normal_pdf(double error, double sigma) {
  return std::exp(-0.5 * error * error / (sigma * sigma)) / (std::sqrt(2.0 * M_PI) * sigma);
}

}  // namespace locd
