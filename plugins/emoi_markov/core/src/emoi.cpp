#include "locd/emoi_markov/emoi.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <opencv2/core.hpp>

#include "locd/sdk/errors.hpp"

namespace locd::emoi {
namespace {

struct DiskOffset {
  int dr, dc;
  double r2_m;  // squared distance in metres
};

// Offsets k with |k| < R' (eq. 7's region), in cells, with r_k^2 in m^2.
std::vector<DiskOffset> disk_offsets(int radius_cells, double resolution) {
  std::vector<DiskOffset> offsets;
  const int r2_limit = radius_cells * radius_cells;
  for (int dr = -radius_cells; dr <= radius_cells; ++dr) {
    for (int dc = -radius_cells; dc <= radius_cells; ++dc) {
      const int r2 = dr * dr + dc * dc;
      if (r2 < r2_limit) offsets.push_back({dr, dc, r2 * resolution * resolution});
    }
  }
  return offsets;
}

void check_radius(const ElevationMap& map, double radius_m) {
  if (!(radius_m > 0) || !std::isfinite(radius_m)) {
    throw ConfigError("EMOI radius " + std::to_string(radius_m) + " m is not allowed; allowed: > 0");
  }
  const int cells = radius_in_cells(radius_m, map.geometry.resolution);
  const int side = std::min(map.geometry.width, map.geometry.height);
  if (2 * cells + 1 > side) {
    throw ConfigError("EMOI radius " + std::to_string(radius_m) + " m (" + std::to_string(cells) +
                      " cells) does not fit in the map (" + std::to_string(map.geometry.width) + " x " +
                      std::to_string(map.geometry.height) + " cells); allowed: 2 R' + 1 <= " + std::to_string(side));
  }
}

}  // namespace

int radius_in_cells(double radius_m, double resolution_m) {
  return std::max(1, static_cast<int>(std::lround(radius_m / resolution_m)));
}

cv::Mat_<double> emoi_direct(const ElevationMap& map, double radius_m) {
  check_radius(map, radius_m);
  const int height = map.geometry.height, width = map.geometry.width;
  const int radius_cells = radius_in_cells(radius_m, map.geometry.resolution);
  const auto offsets = disk_offsets(radius_cells, map.geometry.resolution);
  const double normaliser = radius_m * radius_m;
  cv::Mat_<double> out(height, width, std::numeric_limits<double>::quiet_NaN());
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const float centre = map.elevation(r, c);
      if (!std::isfinite(centre)) continue;
      double sum = 0.0;
      size_t n = 0;
      for (const auto& k : offsets) {
        const int p = r + k.dr, q = c + k.dc;
        if (p < 0 || q < 0 || p >= height || q >= width) continue;
        const float e = map.elevation(p, q);
        if (!std::isfinite(e)) continue;
        sum += k.r2_m * (static_cast<double>(e) - static_cast<double>(centre));
        ++n;
      }
      out(r, c) = sum / static_cast<double>(n) / normaliser;  // eq. 7, normalised by R^2
    }
  }
  return out;
}

std::vector<cv::Mat_<double>> emoi_fft(const ElevationMap& map, const std::vector<double>& radii_m,
                                       const ProgressCallback& progress) {
  const int height = map.geometry.height, width = map.geometry.width;
  const double resolution = map.geometry.resolution;
  int max_radius_cells = 0;
  for (double radius : radii_m) {
    check_radius(map, radius);
    max_radius_cells = std::max(max_radius_cells, radius_in_cells(radius, resolution));
  }
  const auto report = [&](double fraction, const std::string& stage) {
    if (progress) progress(fraction, stage);
  };
  // Linear convolution by circular DFT: padding by R' keeps wrapped indices in the zero band.
  const int padded_rows = cv::getOptimalDFTSize(height + max_radius_cells);
  const int padded_cols = cv::getOptimalDFTSize(width + max_radius_cells);

  // Elevations relative to their mean (EMOI is offset-free; this keeps the sums small).
  double reference = 0.0;
  size_t valid = 0;
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const float e = map.elevation(r, c);
      if (std::isfinite(e)) {
        reference += e;
        ++valid;
      }
    }
  }
  reference = valid ? reference / static_cast<double>(valid) : 0.0;

  cv::Mat elevation_padded = cv::Mat::zeros(padded_rows, padded_cols, CV_64F);
  cv::Mat valid_padded = cv::Mat::zeros(padded_rows, padded_cols, CV_64F);
  for (int r = 0; r < height; ++r) {
    const float* src = map.elevation.ptr<float>(r);
    double* e = elevation_padded.ptr<double>(r);
    double* v = valid_padded.ptr<double>(r);
    for (int c = 0; c < width; ++c) {
      if (std::isfinite(src[c])) {
        e[c] = static_cast<double>(src[c]) - reference;
        v[c] = 1.0;
      }
    }
  }
  const size_t steps = 2 + 5 * radii_m.size();
  size_t step = 0;
  report(0.0, "spectrum of the elevations");
  cv::Mat elevation_spectrum, valid_spectrum;
  cv::dft(elevation_padded, elevation_spectrum, 0, height);
  report(static_cast<double>(++step) / steps, "spectrum of the data mask");
  cv::dft(valid_padded, valid_spectrum, 0, height);
  report(static_cast<double>(++step) / steps, "radii");
  elevation_padded.release();
  valid_padded.release();

  std::vector<cv::Mat_<double>> result;
  for (double radius_m : radii_m) {
    const int radius_cells = radius_in_cells(radius_m, resolution);
    std::ostringstream stage_text;
    stage_text << "radius " << radius_m << " m";
    const std::string stage = stage_text.str();
    // Kernels with their centre at (R', R'): r^2 over the disk (eq. 7's weight) and the disk.
    cv::Mat moment_kernel = cv::Mat::zeros(padded_rows, padded_cols, CV_64F);
    cv::Mat disk_kernel = cv::Mat::zeros(padded_rows, padded_cols, CV_64F);
    for (const auto& k : disk_offsets(radius_cells, resolution)) {
      moment_kernel.at<double>(radius_cells + k.dr, radius_cells + k.dc) = k.r2_m;
      disk_kernel.at<double>(radius_cells + k.dr, radius_cells + k.dc) = 1.0;
    }
    const int kernel_rows = 2 * radius_cells + 1;
    cv::Mat moment_spectrum, disk_spectrum, product;
    cv::dft(moment_kernel, moment_spectrum, 0, kernel_rows);
    cv::dft(disk_kernel, disk_spectrum, 0, kernel_rows);
    moment_kernel.release();
    disk_kernel.release();
    report(static_cast<double>(step += 2) / steps, stage);

    const cv::Rect crop(radius_cells, radius_cells, width, height);
    const int rows_needed = radius_cells + height;
    auto convolve = [&](const cv::Mat& a, const cv::Mat& b) {
      cv::mulSpectrums(a, b, product, 0);
      cv::Mat full;
      cv::dft(product, full, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT, rows_needed);
      report(static_cast<double>(++step) / steps, stage);
      return cv::Mat(full, crop).clone();
    };
    const cv::Mat sum_moment_elevation = convolve(elevation_spectrum, moment_spectrum);  // sum r^2 e
    const cv::Mat sum_moment = convolve(valid_spectrum, moment_spectrum);                 // sum r^2
    const cv::Mat count = convolve(valid_spectrum, disk_spectrum);                        // n
    const double cell_area = resolution * resolution;
    const double normaliser = radius_m * radius_m;
    cv::Mat_<double> out(height, width, std::numeric_limits<double>::quiet_NaN());
    for (int r = 0; r < height; ++r) {
      const float* e = map.elevation.ptr<float>(r);
      const double* s_me = sum_moment_elevation.ptr<double>(r);
      const double* s_m = sum_moment.ptr<double>(r);
      const double* n = count.ptr<double>(r);
      double* o = out.ptr<double>(r);
      for (int c = 0; c < width; ++c) {
        if (!std::isfinite(e[c])) continue;
        // n and sum r^2 / cell_area are integers: rounding removes the DFT's noise from them.
        const double cells = std::round(n[c]);
        const double moment = std::round(s_m[c] / cell_area) * cell_area;
        const double centre = static_cast<double>(e[c]) - reference;
        o[c] = (s_me[c] - centre * moment) / cells / normaliser;
      }
    }
    result.push_back(out);
  }
  report(1.0, "done");
  return result;
}

PointEmoi emoi_at(const cv::Mat_<float>& elevation, double resolution_m, int row, int col,
                  double centre_elevation, double radius_m) {
  const int radius_cells = radius_in_cells(radius_m, resolution_m);
  const int r2_limit = radius_cells * radius_cells;
  double sum = 0.0;
  size_t observed = 0, disk = 0;
  for (int dr = -radius_cells; dr <= radius_cells; ++dr) {
    const int p = row + dr;
    const bool row_inside = p >= 0 && p < elevation.rows;
    const float* line = row_inside ? elevation.ptr<float>(p) : nullptr;
    for (int dc = -radius_cells; dc <= radius_cells; ++dc) {
      const int r2 = dr * dr + dc * dc;
      if (r2 >= r2_limit) continue;
      ++disk;
      const int q = col + dc;
      if (!row_inside || q < 0 || q >= elevation.cols) continue;
      const float e = line[q];
      if (!std::isfinite(e)) continue;
      sum += r2 * resolution_m * resolution_m * (static_cast<double>(e) - centre_elevation);
      ++observed;
    }
  }
  PointEmoi out;
  out.observed = observed;
  out.coverage = disk ? static_cast<double>(observed) / static_cast<double>(disk) : 0.0;
  out.emoi = observed ? sum / static_cast<double>(observed) / (radius_m * radius_m)
                      : std::numeric_limits<double>::quiet_NaN();
  return out;
}

EmoiLayers to_layers(const std::vector<double>& radii_m, const std::vector<cv::Mat_<double>>& emoi) {
  EmoiLayers layers;
  layers.radii_m = radii_m;
  for (const auto& layer : emoi) {
    cv::Mat_<float> single;
    layer.convertTo(single, CV_32F);
    layers.layers.push_back(single);
  }
  return layers;
}

}  // namespace locd::emoi
