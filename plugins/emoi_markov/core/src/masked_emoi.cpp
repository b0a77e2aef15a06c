#include "locd/emoi_markov/masked_emoi.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <opencv2/imgproc.hpp>

#include "locd/sdk/errors.hpp"

namespace locd::emoi {
namespace {
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
}

MaskedEmoiMatcher::MaskedEmoiMatcher(const ElevationMap& dsm, std::vector<double> radii_m, double match_resolution_m,
                                     double shape_edge_step_m)
    : radii_m_(std::move(radii_m)) {
  const double res = dsm.geometry.resolution;
  factor_ = std::max(1, static_cast<int>(std::lround(match_resolution_m / res)));
  const int rows = (dsm.geometry.height + factor_ - 1) / factor_;
  const int cols = (dsm.geometry.width + factor_ - 1) / factor_;
  coarse_.geometry.resolution = res * factor_;
  coarse_.geometry.origin = dsm.geometry.origin;
  coarse_.geometry.width = cols;
  coarse_.geometry.height = rows;
  // Mean of the cells with data in each matching cell (the robot's patch is pooled the same way).
  cv::Mat_<double> sum(rows, cols, 0.0);
  cv::Mat_<int> count(rows, cols, 0);
  for (int r = 0; r < dsm.geometry.height; ++r) {
    const float* e = dsm.elevation.ptr<float>(r);
    double* s = sum.ptr<double>(r / factor_);
    int* n = count.ptr<int>(r / factor_);
    for (int c = 0; c < dsm.geometry.width; ++c) {
      if (!std::isfinite(e[c])) continue;
      s[c / factor_] += e[c];
      n[c / factor_] += 1;
    }
  }
  coarse_.elevation = cv::Mat_<float>(rows, cols, kNaN);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if (count(r, c) > 0) coarse_.elevation(r, c) = static_cast<float>(sum(r, c) / count(r, c));
    }
  }
  ground_ = coarse_.elevation;
  double max_radius = 0.0;
  for (double radius : radii_m_) max_radius = std::max(max_radius, radius);
  patch_radius_ = radius_in_cells(max_radius, coarse_.geometry.resolution);
  if (2 * patch_radius_ + 1 > std::min(rows, cols)) {
    throw ConfigError("EMOI radius " + std::to_string(max_radius) + " m does not fit in the map (" +
                      std::to_string(dsm.geometry.width * res) + " x " + std::to_string(dsm.geometry.height * res) +
                      " m); allowed: a diameter below the map's shorter side");
  }
  double total = 0.0;
  size_t n = 0;
  for (const float v : coarse_.elevation) {
    if (std::isfinite(v)) {
      total += v;
      ++n;
    }
  }
  reference_ = n ? total / static_cast<double>(n) : 0.0;
  // Direct sums (match_at) in float: elevations relative to the reference, 0 where no data.
  filled_ = cv::Mat_<float>(rows, cols, 0.0f);
  valid_ = cv::Mat_<float>(rows, cols, 0.0f);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if (!std::isfinite(coarse_.elevation(r, c))) continue;
      filled_(r, c) = static_cast<float>(coarse_.elevation(r, c) - reference_);
      valid_(r, c) = 1.0f;
    }
  }
  // The shape residual's cells: data, and (with shape_edge_step_m) no step above it to a
  // neighbour with data.
  shape_valid_ = valid_.clone();
  if (shape_edge_step_m > 0.0) {
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        if (valid_(r, c) == 0.0f) continue;
        float low = coarse_.elevation(r, c), high = low;
        for (int dr = -1; dr <= 1; ++dr) {
          for (int dc = -1; dc <= 1; ++dc) {
            const int rr = r + dr, cc = c + dc;
            if (rr < 0 || cc < 0 || rr >= rows || cc >= cols || valid_(rr, cc) == 0.0f) continue;
            low = std::min(low, coarse_.elevation(rr, cc));
            high = std::max(high, coarse_.elevation(rr, cc));
          }
        }
        if (high - low > shape_edge_step_m) shape_valid_(r, c) = 0.0f;
      }
    }
  }
  const cv::Mat nodata = (valid_ == 0.0f) / 255;  // 1 where no data
  cv::integral(nodata, nodata_integral_, CV_32S);
  padded_rows_ = cv::getOptimalDFTSize(rows + patch_radius_);
  padded_cols_ = cv::getOptimalDFTSize(cols + patch_radius_);
  cv::Mat elevation = cv::Mat::zeros(padded_rows_, padded_cols_, CV_64F);
  cv::Mat valid = cv::Mat::zeros(padded_rows_, padded_cols_, CV_64F);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const float v = coarse_.elevation(r, c);
      if (!std::isfinite(v)) continue;
      elevation.at<double>(r, c) = v - reference_;
      valid.at<double>(r, c) = 1.0;
    }
  }
  cv::dft(elevation, elevation_spectrum_, 0, rows);
  cv::dft(valid, valid_spectrum_, 0, rows);
}

MaskedEmoiMatcher::Match MaskedEmoiMatcher::robot_side(const cv::Mat_<float>& patch,
                                                       std::vector<std::vector<Offset>>& disks) const {
  const int side = 2 * patch_radius_ + 1;
  if (patch.rows != side || patch.cols != side) {
    throw InputError("masked EMOI patch is " + std::to_string(patch.cols) + " x " + std::to_string(patch.rows) +
                     "; expected " + std::to_string(side) + " x " + std::to_string(side));
  }
  const double cell = coarse_.geometry.resolution;
  Match out;
  disks.assign(radii_m_.size(), {});
  for (size_t k = 0; k < radii_m_.size(); ++k) {
    const double radius_m = radii_m_[k];
    const int radius = radius_in_cells(radius_m, cell);
    double robot_sum = 0.0, moment_sum = 0.0;
    size_t disk = 0;
    for (int dr = -radius; dr <= radius; ++dr) {
      for (int dc = -radius; dc <= radius; ++dc) {
        const int r2 = dr * dr + dc * dc;
        if (r2 >= radius * radius) continue;
        ++disk;
        const float v = patch(patch_radius_ + dr, patch_radius_ + dc);
        if (!std::isfinite(v)) continue;
        const double r2_m = r2 * cell * cell;
        robot_sum += r2_m * v;
        moment_sum += r2_m;
        disks[k].push_back({dr, dc, r2_m});
      }
    }
    const size_t observed = disks[k].size();
    out.observed.push_back(observed);
    out.offset_gain.push_back(observed ? -moment_sum / static_cast<double>(observed) / (radius_m * radius_m) : 0.0);
    out.coverage.push_back(disk ? static_cast<double>(observed) / static_cast<double>(disk) : 0.0);
    out.robot_emoi.push_back(observed ? robot_sum / static_cast<double>(observed) / (radius_m * radius_m)
                                      : std::numeric_limits<double>::quiet_NaN());
  }
  return out;
}

MaskedEmoiMatcher::Match MaskedEmoiMatcher::match(const cv::Mat_<float>& patch) const {
  std::vector<std::vector<Offset>> disks;
  Match out = robot_side(patch, disks);
  const int side = 2 * patch_radius_ + 1;
  const int rows = coarse_.geometry.height, cols = coarse_.geometry.width;
  for (size_t k = 0; k < radii_m_.size(); ++k) {
    const double radius_m = radii_m_[k];
    cv::Mat_<float> layer(rows, cols, kNaN);
    if (disks[k].empty()) {
      out.dsm_emoi.push_back(layer);
      continue;
    }
    // Kernels flipped in both axes: the DFT convolves, the match correlates.
    cv::Mat moment_kernel = cv::Mat::zeros(padded_rows_, padded_cols_, CV_64F);
    cv::Mat mask_kernel = cv::Mat::zeros(padded_rows_, padded_cols_, CV_64F);
    for (const Offset& o : disks[k]) {
      moment_kernel.at<double>(patch_radius_ - o.dr, patch_radius_ - o.dc) = o.r2_m;
      mask_kernel.at<double>(patch_radius_ - o.dr, patch_radius_ - o.dc) = 1.0;
    }
    cv::Mat moment_spectrum, mask_spectrum, product;
    cv::dft(moment_kernel, moment_spectrum, 0, side);
    cv::dft(mask_kernel, mask_spectrum, 0, side);
    const cv::Rect crop(patch_radius_, patch_radius_, cols, rows);
    auto correlate = [&](const cv::Mat& a, const cv::Mat& b) {
      cv::mulSpectrums(a, b, product, 0);
      cv::Mat full;
      cv::dft(product, full, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT, patch_radius_ + rows);
      return cv::Mat(full, crop).clone();
    };
    const cv::Mat sum_moment_elevation = correlate(elevation_spectrum_, moment_spectrum);
    const cv::Mat sum_moment = correlate(valid_spectrum_, moment_spectrum);
    const cv::Mat count = correlate(valid_spectrum_, mask_spectrum);
    const double normaliser = radius_m * radius_m;
    for (int r = 0; r < rows; ++r) {
      const float* ground = ground_.ptr<float>(r);
      const double* s_me = sum_moment_elevation.ptr<double>(r);
      const double* s_m = sum_moment.ptr<double>(r);
      const double* n = count.ptr<double>(r);
      float* o = layer.ptr<float>(r);
      for (int c = 0; c < cols; ++c) {
        const double cells = std::round(n[c]);
        if (!std::isfinite(ground[c]) || cells < 0.5) continue;
        o[c] = static_cast<float>((s_me[c] - (ground[c] - reference_) * s_m[c]) / cells / normaliser);
      }
    }
    out.dsm_emoi.push_back(layer);
  }
  return out;
}

cv::Mat_<float> MaskedEmoiMatcher::to_fine(const cv::Mat_<float>& coarse, int fine_rows, int fine_cols) const {
  if (factor_ == 1) return coarse(cv::Rect(0, 0, fine_cols, fine_rows)).clone();
  cv::Mat_<float> fine;
  cv::resize(coarse, fine, cv::Size(coarse.cols * factor_, coarse.rows * factor_), 0, 0, cv::INTER_LINEAR);
  if (fine.rows == fine_rows && fine.cols == fine_cols) return fine;
  return fine(cv::Rect(0, 0, fine_cols, fine_rows)).clone();
}

cv::Mat_<float> MaskedEmoiMatcher::to_fine_window(const cv::Mat_<float>& coarse_window, const cv::Rect& coarse_rect,
                                                  int fine_rows, int fine_cols, cv::Rect& fine_rect) const {
  if (coarse_window.size() != coarse_rect.size()) throw InputError("matching-grid window does not match its rectangle");
  fine_rect = cv::Rect(coarse_rect.x * factor_, coarse_rect.y * factor_, coarse_rect.width * factor_,
                       coarse_rect.height * factor_) &
              cv::Rect(0, 0, fine_cols, fine_rows);
  if (fine_rect.area() == 0) return cv::Mat_<float>(fine_rect.size(), 0.0f);
  if (factor_ == 1) return coarse_window(cv::Rect(0, 0, fine_rect.width, fine_rect.height)).clone();
  // Same phase as to_fine: fine cell (x + 0.5) / factor - 0.5 in coarse cells, offsets whole.
  cv::Mat_<float> fine;
  cv::resize(coarse_window, fine, cv::Size(coarse_window.cols * factor_, coarse_window.rows * factor_), 0, 0,
             cv::INTER_LINEAR);
  return fine(cv::Rect(0, 0, fine_rect.width, fine_rect.height)).clone();
}

cv::Mat_<float> MaskedEmoiMatcher::pool(const cv::Mat_<float>& fine) const {
  return pool(fine, cv::Rect(0, 0, fine.cols, fine.rows));
}

cv::Mat_<float> MaskedEmoiMatcher::pool(const cv::Mat_<float>& fine, const cv::Rect& nonzero) const {
  cv::Mat_<float> coarse(coarse_.geometry.height, coarse_.geometry.width, 0.0f);
  const cv::Rect area = nonzero & cv::Rect(0, 0, fine.cols, fine.rows);
  const int last_col = coarse.cols - 1;
  for (int r = area.y; r < area.y + area.height; ++r) {
    const float* f = fine.ptr<float>(r);
    float* c = coarse.ptr<float>(std::min(r / factor_, coarse.rows - 1));
    for (int q = area.x; q < area.x + area.width;) {
      const int column = std::min(q / factor_, last_col);
      const int end = column == last_col ? area.x + area.width : std::min((column + 1) * factor_, area.x + area.width);
      float sum = 0.0f;
      for (; q < end; ++q) sum += f[q];
      c[column] += sum;
    }
  }
  return coarse;
}

cv::Mat_<float> MaskedEmoiMatcher::coarse_log_likelihood(const Match& match, const SensorModelConfig& sensor,
                                                         std::vector<double>* weights_out) const {
  if (match.robot_emoi.size() != radii_m_.size() || match.dsm_emoi.size() != radii_m_.size()) {
    throw InputError("masked EMOI match does not hold one value per radius");
  }
  const int rows = match.dsm_emoi[0].rows, cols = match.dsm_emoi[0].cols;
  std::vector<double> weights;
  for (size_t i = 0; i < match.robot_emoi.size(); ++i) {
    weights.push_back(std::isfinite(match.robot_emoi[i]) ? coverage_weight(match.coverage[i], sensor) : 0.0);
  }
  if (weights_out) *weights_out = weights;
  const float floor_exponent = static_cast<float>(std::log(sensor.min_likelihood));
  const float inverse_variance = static_cast<float>(1.0 / (sensor.sigma_m * sensor.sigma_m));
  cv::Mat_<float> coarse(rows, cols, 0.0f);
  const double offset_precision =
      sensor.ground_offset_stddev_m > 0 ? 1.0 / (sensor.ground_offset_stddev_m * sensor.ground_offset_stddev_m) : 0.0;
  if (offset_precision == 0.0) {
    for (size_t i = 0; i < weights.size(); ++i) {
      if (weights[i] <= 0.0) continue;
      const float robot = static_cast<float>(match.robot_emoi[i]);
      const float scale = static_cast<float>(weights[i]) * inverse_variance;
      for (int r = 0; r < rows; ++r) {
        const float* layer = match.dsm_emoi[i].ptr<float>(r);
        float* e = coarse.ptr<float>(r);
        for (int c = 0; c < cols; ++c) {
          const float d = layer[c] - robot;
          e[c] -= scale * d * d;  // eq. 8, multiplied over radii
        }
      }
    }
  } else {
    // residual d_R = robot_R - DSM_R(x) = g_R * delta + noise: integrate delta ~ N(0, s^2) out.
    // exponent = -sum w d^2 / sigma^2 + (sum w g d / sigma^2)^2 / (1 / s^2 + sum w g^2 / sigma^2)
    cv::Mat_<float> cross(rows, cols, 0.0f);
    double information = offset_precision;
    for (size_t i = 0; i < weights.size(); ++i) {
      if (weights[i] <= 0.0) continue;
      const float robot = static_cast<float>(match.robot_emoi[i]);
      const float scale = static_cast<float>(weights[i]) * inverse_variance;
      const float gain = static_cast<float>(match.offset_gain[i]);
      information += weights[i] * inverse_variance * match.offset_gain[i] * match.offset_gain[i];
      for (int r = 0; r < rows; ++r) {
        const float* layer = match.dsm_emoi[i].ptr<float>(r);
        float* e = coarse.ptr<float>(r);
        float* x = cross.ptr<float>(r);
        for (int c = 0; c < cols; ++c) {
          const float d = robot - layer[c];
          e[c] -= scale * d * d;
          x[c] += scale * gain * d;
        }
      }
    }
    const float inverse_information = static_cast<float>(1.0 / information);
    for (int r = 0; r < rows; ++r) {
      float* e = coarse.ptr<float>(r);
      const float* x = cross.ptr<float>(r);
      for (int c = 0; c < cols; ++c) e[c] += x[c] * x[c] * inverse_information;
    }
  }
  if (sensor.shape_sigma_m > 0.0 && !match.shape_residual.empty()) {
    // The local map's elevations against the DSM's (beyond the paper): a Gaussian on the RMS
    // residual, log p = -residual / (2 shape_sigma^2).
    const float scale = static_cast<float>(0.5 / (sensor.shape_sigma_m * sensor.shape_sigma_m));
    coarse -= scale * match.shape_residual;
  }
  cv::patchNaNs(coarse, floor_exponent);
  cv::max(coarse, floor_exponent, coarse);
  return coarse;
}

cv::Mat_<float> MaskedEmoiMatcher::likelihood(const Match& match, const SensorModelConfig& sensor, int fine_rows,
                                              int fine_cols, std::vector<double>* weights) const {
  cv::Mat_<float> coarse = coarse_log_likelihood(match, sensor, weights);
  cv::exp(coarse, coarse);
  return to_fine(coarse, fine_rows, fine_cols);
}

}  // namespace locd::emoi
