#include "locd/emoi_markov/markov_grid.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Core>
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

double coverage_weight(double coverage, const SensorModelConfig& sensor) {
  if (!(coverage >= sensor.min_coverage) || coverage <= 0.0) return 0.0;
  if (sensor.full_coverage <= sensor.min_coverage) return 1.0;
  return std::clamp((coverage - sensor.min_coverage) / (sensor.full_coverage - sensor.min_coverage), 0.0, 1.0);
}

cv::Mat_<uchar> layers_support(const EmoiLayers& layers) {
  cv::Mat_<uchar> support(layers.layers.at(0).size(), uchar(1));
  for (const auto& layer : layers.layers) {
    for (int r = 0; r < layer.rows; ++r) {
      const float* v = layer.ptr<float>(r);
      uchar* s = support.ptr<uchar>(r);
      for (int c = 0; c < layer.cols; ++c) s[c] = s[c] && std::isfinite(v[c]);
    }
  }
  return support;
}

cv::Mat_<float> full_disk_log_likelihood(const EmoiLayers& layers, const EmoiObservation& z,
                                         const SensorModelConfig& sensor, std::vector<double>* weights_out) {
  const size_t radii = layers.layers.size();
  if (radii == 0 || z.emoi.size() != radii || z.coverage.size() != radii) {
    throw InputError("EMOI observation has " + std::to_string(z.emoi.size()) + " values; the map has " +
                     std::to_string(radii) + " radii");
  }
  std::vector<double> weights(radii, 0.0);
  for (size_t i = 0; i < radii; ++i) weights[i] = std::isfinite(z.emoi[i]) ? coverage_weight(z.coverage[i], sensor) : 0.0;
  if (weights_out) *weights_out = weights;
  const float inverse_variance = static_cast<float>(1.0 / (sensor.sigma_m * sensor.sigma_m));
  cv::Mat_<float> exponent(layers.layers[0].size(), 0.0f);
  for (size_t i = 0; i < radii; ++i) {
    if (weights[i] <= 0.0) continue;
    const float robot = static_cast<float>(z.emoi[i]);
    const float scale = static_cast<float>(weights[i]) * inverse_variance;
    for (int r = 0; r < exponent.rows; ++r) {
      const float* layer = layers.layers[i].ptr<float>(r);
      float* e = exponent.ptr<float>(r);
      for (int c = 0; c < exponent.cols; ++c) {
        const float d = layer[c] - robot;
        e[c] -= scale * d * d;  // eq. 8, multiplied over radii
      }
    }
  }
  return exponent;
}

MarkovGrid::MarkovGrid(GridGeometry geometry, cv::Mat_<uchar> support)
    : geometry_(geometry), support_(std::move(support)) {
  if (support_.rows != geometry_.height || support_.cols != geometry_.width) {
    throw ConfigError("Markov grid support does not match the DSM size");
  }
  support_cells_ = static_cast<size_t>(cv::countNonZero(support_));
  full_support_ = support_cells_ == geometry_.size();
  if (support_cells_ == 0) throw ConfigError("the DSM has no cell the robot could occupy (no data)");
  set_uniform();
}

void MarkovGrid::set_uniform() {
  belief_ = cv::Mat_<float>(geometry_.height, geometry_.width, 0.0f);
  belief_.setTo(1.0f / static_cast<float>(support_cells_), support_);
  occupied_ = cv::Rect(0, 0, geometry_.width, geometry_.height);
}

void MarkovGrid::set_gaussian(const Eigen::Vector2d& mean, double stddev_m) {
  const double s = std::max(stddev_m, geometry_.resolution);
  belief_ = cv::Mat_<float>(geometry_.height, geometry_.width, 0.0f);
  occupied_ = cv::Rect(0, 0, geometry_.width, geometry_.height);
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
  if (occupied_.area() == 0) return 0.0;
  cv::Mat_<float> window = belief_(occupied_);
  const double mass = cv::sum(window)[0];
  if (!(mass > 0.0)) return mass;
  const float scale = static_cast<float>(1.0 / mass);
  int low_row = window.rows, high_row = -1, low_col = window.cols, high_col = -1;
  for (int r = 0; r < window.rows; ++r) {
    float* b = window.ptr<float>(r);
    for (int c = 0; c < window.cols; ++c) {
      const float v = b[c] * scale;
      b[c] = v < kFlushBelow ? 0.0f : v;
    }
    int first = 0, last = window.cols - 1;
    while (first < window.cols && b[first] == 0.0f) ++first;
    if (first == window.cols) continue;
    while (b[last] == 0.0f) --last;
    low_row = std::min(low_row, r);
    high_row = r;
    low_col = std::min(low_col, first);
    high_col = std::max(high_col, last);
  }
  occupied_ = high_row < 0 ? cv::Rect()
                           : cv::Rect(occupied_.x + low_col, occupied_.y + low_row, high_col - low_col + 1,
                                      high_row - low_row + 1);
  return mass;
}

namespace {
cv::Rect grown(const cv::Rect& r, int margin) {
  return cv::Rect(r.x - margin, r.y - margin, r.width + 2 * margin, r.height + 2 * margin);
}
}  // namespace

MotionUpdateReport MarkovGrid::motion_update(const Eigen::Vector2d& displacement_m, double blur_stddev_m) {
  MotionUpdateReport report;
  report.mass_before = occupied_.area() > 0 ? cv::sum(belief_(occupied_))[0] : 0.0;
  const double res = geometry_.resolution;
  const double sigma_cells = blur_stddev_m / res;
  const Eigen::Vector2d shift_cells = displacement_m / res;
  const cv::Rect all(0, 0, belief_.cols, belief_.rows);
  // Everything runs on the window the occupied cells can reach (outside it the result is zero,
  // as on the whole grid with a zero border); a uniform belief's window is the whole grid.
  cv::Rect window;
  cv::Mat_<float> moved;
  if (sigma_cells > 3.0) {
    // Coarse-to-fine in spirit: a blur wider than 3 cells hides any sub-cell part of the shift
    // (at most half a cell), so the shift is rounded to whole cells and done as a copy.
    const int dx = static_cast<int>(std::lround(shift_cells.x())), dy = static_cast<int>(std::lround(shift_cells.y()));
    const std::vector<int> widths = box_widths_for_gaussian(sigma_cells, 3);
    int reach = 0;
    for (int width : widths) reach += width / 2;
    const cv::Rect target = (occupied_ + cv::Point(dx, dy)) & all;
    window = grown(target, reach) & all;
    moved = cv::Mat_<float>(window.size(), 0.0f);
    if (target.area() > 0) belief_(target - cv::Point(dx, dy)).copyTo(moved(target - window.tl()));
    for (int width : widths) {
      if (width > 1) cv::blur(moved, moved, cv::Size(width, width), cv::Point(-1, -1), cv::BORDER_CONSTANT);
    }
  } else {
    // bel-(x) = bel(x - u): bilinear shift, every source cell's weights sum to one.
    const int half = sigma_cells > 0.3 ? static_cast<int>(std::ceil(3.0 * sigma_cells)) : 0;
    const cv::Rect shifted(occupied_.x + static_cast<int>(std::floor(shift_cells.x())),
                           occupied_.y + static_cast<int>(std::floor(shift_cells.y())), occupied_.width + 1,
                           occupied_.height + 1);
    window = occupied_.area() > 0 ? grown(shifted, half + 1) & all : cv::Rect();
    if (window.area() > 0) {
      const cv::Matx23d shift(1, 0, shift_cells.x() - window.x, 0, 1, shift_cells.y() - window.y);
      cv::warpAffine(belief_, moved, shift, window.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0.0);
      if (half > 0) {
        cv::GaussianBlur(moved, moved, cv::Size(2 * half + 1, 2 * half + 1), sigma_cells, sigma_cells,
                         cv::BORDER_CONSTANT);
      }
    }
  }
  if (window == all) {
    belief_ = moved;
  } else {
    if (occupied_.area() > 0) belief_(occupied_).setTo(0.0f);
    if (window.area() > 0) moved.copyTo(belief_(window));
  }
  occupied_ = window;
  if (window.area() > 0 && !full_support_) belief_(window).setTo(0.0f, support_(window) == 0);
  const double mass = normalise();
  report.mass_lost = std::max(0.0, report.mass_before - mass);
  if (!(mass > 1e-30)) {
    set_uniform();
    report.reset = true;
  }
  return report;
}

SensorUpdateReport MarkovGrid::sensor_update(const cv::Mat_<float>& log_likelihood, double min_likelihood) {
  if (log_likelihood.size() != belief_.size()) throw InputError("likelihood grid does not match the belief grid");
  const float floor_exponent = static_cast<float>(std::log(min_likelihood));
  cv::Mat_<float> p = log_likelihood.clone();
  cv::patchNaNs(p, floor_exponent);  // no data there: the floor
  cv::max(p, floor_exponent, p);
  cv::exp(p, p);
  return sensor_update_likelihood(p);
}

SensorUpdateReport MarkovGrid::sensor_update_likelihood(const cv::Mat_<float>& likelihood) {
  if (likelihood.size() != belief_.size()) throw InputError("likelihood grid does not match the belief grid");
  return sensor_update_likelihood(likelihood, cv::Rect(0, 0, belief_.cols, belief_.rows), 0.0f);
}

SensorUpdateReport MarkovGrid::sensor_update_likelihood(const cv::Mat_<float>& window_likelihood,
                                                        const cv::Rect& window, float outside) {
  SensorUpdateReport report;
  if (window_likelihood.size() != window.size()) throw InputError("likelihood window does not match its rectangle");
  double evidence = 0.0;
  // Only the occupied cells change (zero stays zero).
  for (int r = occupied_.y; r < occupied_.y + occupied_.height; ++r) {
    float* b = belief_.ptr<float>(r);
    const bool row_inside = r >= window.y && r < window.y + window.height;
    const float* p = row_inside ? window_likelihood.ptr<float>(r - window.y) : nullptr;
    const int in_begin = row_inside ? std::clamp(window.x, occupied_.x, occupied_.x + occupied_.width) : occupied_.x;
    const int in_end =
        row_inside ? std::clamp(window.x + window.width, in_begin, occupied_.x + occupied_.width) : occupied_.x;
    float row_sum = 0.0f;
    for (int c = occupied_.x; c < in_begin; ++c) {
      b[c] *= outside;
      row_sum += b[c];
    }
    for (int c = in_begin; c < in_end; ++c) {
      b[c] *= p[c - window.x];
      row_sum += b[c];
    }
    for (int c = std::max(in_end, in_begin); c < occupied_.x + occupied_.width; ++c) {
      b[c] *= outside;
      row_sum += b[c];
    }
    evidence += row_sum;
  }
  report.evidence = evidence;
  report.applied = true;
  if (!(evidence > 0.0)) {
    set_uniform();
    return report;
  }
  normalise();
  return report;
}

BeliefSummary MarkovGrid::summary() const {
  BeliefSummary s;
  const double res = geometry_.resolution;
  if (occupied_.area() == 0) {
    s.covariance = Eigen::Matrix2d::Identity() * (res * res / 12.0);
    return s;
  }
  double max_value = 0.0;
  cv::Point max_location;
  cv::minMaxLoc(belief_(occupied_), nullptr, &max_value, nullptr, &max_location);
  max_location += occupied_.tl();
  s.mode = geometry_.center_of(max_location.y, max_location.x);
  s.max_probability = max_value;
  double mass = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0, squares = 0;
  // Per row in float (vectorised), across rows in double: sum p, p dx, p dx^2, p^2.
  Eigen::ArrayXf dx(occupied_.width);
  for (int c = 0; c < occupied_.width; ++c) dx[c] = static_cast<float>((occupied_.x + c - max_location.x) * res);
  for (int r = occupied_.y; r < occupied_.y + occupied_.height; ++r) {
    const Eigen::Map<const Eigen::ArrayXf> p(belief_.ptr<float>(r) + occupied_.x, occupied_.width);
    const double dy = (r - max_location.y) * res;
    const double row_mass = p.sum(), row_x = (p * dx).sum(), row_xx = (p * dx * dx).sum();
    mass += row_mass;
    sx += row_x;
    sy += dy * row_mass;
    sxx += row_xx;
    syy += dy * dy * row_mass;
    sxy += dy * row_x;
    squares += p.square().sum();
  }
  if (mass > 0) {
    s.mean = s.mode + Eigen::Vector2d(sx / mass, sy / mass);
    s.covariance << sxx / mass, sxy / mass, sxy / mass, syy / mass;
  }
  s.covariance += Eigen::Matrix2d::Identity() * (res * res / 12.0);  // the cell's own extent
  s.effective_cells = squares > 0 ? mass * mass / squares : 0.0;
  return s;
}

}  // namespace locd::emoi
