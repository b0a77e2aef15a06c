#include "locd/emoi_markov/markov_grid.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "locd/sdk/errors.hpp"

namespace locd::emoi {
namespace {
constexpr float kFlushBelow = 1e-30f;  // keeps the float belief out of denormals
}

std::vector<int> box_widths_for_gaussian(double sigma_cells, int passes) {
  const double ideal = std::sqrt(12.0 * sigma_cells * sigma_cells / passes + 1.0);
  int lower = static_cast<int>(std::floor(ideal));
  if (lower % 2 == 0) --lower;
  lower = std::max(lower, 1);
  const int upper = lower + 2;
  const double m = (12.0 * sigma_cells * sigma_cells - passes * lower * lower - 4.0 * passes * lower - 3.0 * passes) /
                   (-4.0 * lower - 4.0);
  const int lower_passes = std::clamp(static_cast<int>(std::lround(m)), 0, passes);
  std::vector<int> widths;
  for (int i = 0; i < passes; ++i) widths.push_back(i < lower_passes ? lower : upper);
  return widths;
}

MarkovGrid::MarkovGrid(GridGeometry geometry, EmoiLayers layers, SensorModelConfig sensor)
    : geometry_(geometry), layers_(std::move(layers)), sensor_(sensor) {
  if (layers_.layers.empty() || layers_.layers.size() != layers_.radii_m.size()) {
    throw ConfigError("Markov grid needs one EMOI layer per radius");
  }
  support_ = cv::Mat_<uchar>(geometry_.height, geometry_.width, uchar(1));
  for (const auto& layer : layers_.layers) {
    if (layer.rows != geometry_.height || layer.cols != geometry_.width) {
      throw ConfigError("EMOI layer size does not match the DSM");
    }
    for (int r = 0; r < layer.rows; ++r) {
      const float* v = layer.ptr<float>(r);
      uchar* s = support_.ptr<uchar>(r);
      for (int c = 0; c < layer.cols; ++c) s[c] = s[c] && std::isfinite(v[c]);
    }
  }
  support_cells_ = static_cast<size_t>(cv::countNonZero(support_));
  if (support_cells_ == 0) throw ConfigError("the DSM has no cell with an EMOI at every radius");
  set_uniform();
}

void MarkovGrid::set_uniform() {
  belief_ = cv::Mat_<float>(geometry_.height, geometry_.width, 0.0f);
  belief_.setTo(1.0f / static_cast<float>(support_cells_), support_);
}

void MarkovGrid::set_gaussian(const Eigen::Vector2d& mean, double stddev_m) {
  const double s = std::max(stddev_m, geometry_.resolution);
  belief_ = cv::Mat_<float>(geometry_.height, geometry_.width, 0.0f);
  for (int r = 0; r < geometry_.height; ++r) {
    const uchar* support = support_.ptr<uchar>(r);
    float* b = belief_.ptr<float>(r);
    for (int c = 0; c < geometry_.width; ++c) {
      if (!support[c]) continue;
      const Eigen::Vector2d d = geometry_.center_of(r, c) - mean;
      b[c] = static_cast<float>(std::exp(-0.5 * d.squaredNorm() / (s * s)));
    }
  }
  if (normalise() <= 0.0) set_uniform();
}

double MarkovGrid::normalise() {
  const double mass = cv::sum(belief_)[0];
  if (mass > 0.0) belief_ *= 1.0 / mass;
  return mass;
}

MotionUpdateReport MarkovGrid::motion_update(const Eigen::Vector2d& displacement_m, double blur_stddev_m) {
  MotionUpdateReport report;
  report.mass_before = cv::sum(belief_)[0];
  const double res = geometry_.resolution;
  if (displacement_m.squaredNorm() > 0.0) {
    // bel-(x) = bel(x - u): bilinear shift, every source cell's weights sum to one.
    const cv::Matx23d shift(1, 0, displacement_m.x() / res, 0, 1, displacement_m.y() / res);
    cv::Mat_<float> moved;
    cv::warpAffine(belief_, moved, shift, belief_.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0.0);
    belief_ = moved;
  }
  const double sigma_cells = blur_stddev_m / res;
  if (sigma_cells > 3.0) {
    for (int width : box_widths_for_gaussian(sigma_cells, 3)) {
      if (width > 1) {
        cv::blur(belief_, belief_, cv::Size(width, width), cv::Point(-1, -1), cv::BORDER_CONSTANT);
      }
    }
  } else if (sigma_cells > 0.3) {
    const int half = static_cast<int>(std::ceil(3.0 * sigma_cells));
    cv::GaussianBlur(belief_, belief_, cv::Size(2 * half + 1, 2 * half + 1), sigma_cells, sigma_cells,
                     cv::BORDER_CONSTANT);
  }
  cv::Mat_<float> masked(belief_.size(), 0.0f);
  belief_.copyTo(masked, support_);
  belief_ = masked;
  const double mass = normalise();
  report.mass_lost = std::max(0.0, report.mass_before - mass);
  if (!(mass > 1e-30)) {
    set_uniform();
    report.reset = true;
  }
  return report;
}

cv::Mat_<float> MarkovGrid::likelihood(const EmoiObservation& z, std::vector<double>* weights_out) const {
  const size_t radii = layers_.layers.size();
  if (z.emoi.size() != radii || z.coverage.size() != radii) {
    throw InputError("EMOI observation has " + std::to_string(z.emoi.size()) + " values; the map has " +
                     std::to_string(radii) + " radii");
  }
  std::vector<float> weights(radii, 0.0f);
  for (size_t i = 0; i < radii; ++i) {
    const double c = z.coverage[i];
    if (!std::isfinite(z.emoi[i]) || c < sensor_.min_coverage) continue;
    const double span = std::max(1e-9, sensor_.full_coverage - sensor_.min_coverage);
    weights[i] = static_cast<float>(std::clamp((c - sensor_.min_coverage) / span, 0.0, 1.0));
    if (sensor_.full_coverage <= sensor_.min_coverage) weights[i] = 1.0f;
  }
  if (weights_out) weights_out->assign(weights.begin(), weights.end());
  const float inverse_variance = static_cast<float>(1.0 / (sensor_.sigma_m * sensor_.sigma_m));
  // Exponent of eq. 8, multiplied over radii: -sum_R w_R (EMOI_robot - EMOI_DSM)^2 / sigma^2.
  cv::Mat_<float> exponent(geometry_.height, geometry_.width, 0.0f);
  for (size_t i = 0; i < radii; ++i) {
    if (weights[i] <= 0.0f) continue;
    const float robot = static_cast<float>(z.emoi[i]);
    const float scale = weights[i] * inverse_variance;
    for (int r = 0; r < geometry_.height; ++r) {
      const float* layer = layers_.layers[i].ptr<float>(r);
      float* e = exponent.ptr<float>(r);
      for (int c = 0; c < geometry_.width; ++c) {
        const float d = layer[c] - robot;
        e[c] -= scale * d * d;
      }
    }
  }
  const float floor_exponent = static_cast<float>(std::log(sensor_.min_likelihood));
  cv::patchNaNs(exponent, floor_exponent);  // cells without data (off-support, belief 0)
  cv::max(exponent, floor_exponent, exponent);
  cv::Mat_<float> result;
  cv::exp(exponent, result);
  return result;
}

SensorUpdateReport MarkovGrid::sensor_update(const EmoiObservation& z) {
  SensorUpdateReport report;
  const cv::Mat_<float> p = likelihood(z, &report.weights);
  report.applied = std::any_of(report.weights.begin(), report.weights.end(), [](double w) { return w > 0; });
  if (!report.applied) {
    report.evidence = 1.0;
    return report;
  }
  cv::multiply(belief_, p, belief_);
  report.evidence = normalise();
  if (!(report.evidence > 0.0)) {
    set_uniform();
    return report;
  }
  cv::threshold(belief_, belief_, kFlushBelow, 0.0, cv::THRESH_TOZERO);
  return report;
}

BeliefSummary MarkovGrid::summary() const {
  BeliefSummary s;
  double max_value = 0.0;
  cv::Point max_location;
  cv::minMaxLoc(belief_, nullptr, &max_value, nullptr, &max_location);
  s.mode = geometry_.center_of(max_location.y, max_location.x);
  s.max_probability = max_value;
  double mass = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0, entropy = 0;
  const double res = geometry_.resolution;
  for (int r = 0; r < geometry_.height; ++r) {
    const float* b = belief_.ptr<float>(r);
    const double dy = (r - max_location.y) * res;
    for (int c = 0; c < geometry_.width; ++c) {
      const double p = b[c];
      if (p <= 0.0) continue;
      const double dx = (c - max_location.x) * res;
      mass += p;
      sx += p * dx;
      sy += p * dy;
      sxx += p * dx * dx;
      syy += p * dy * dy;
      sxy += p * dx * dy;
      entropy -= p * std::log(p);
    }
  }
  if (mass > 0) {
    s.mean = s.mode + Eigen::Vector2d(sx / mass, sy / mass);
    s.covariance << sxx / mass, sxy / mass, sxy / mass, syy / mass;
  }
  s.covariance += Eigen::Matrix2d::Identity() * (res * res / 12.0);  // the cell's own extent
  s.entropy = entropy;
  return s;
}

}  // namespace locd::emoi
