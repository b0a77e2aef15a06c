#include "locd/emoi_markov/belief_assessment.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <opencv2/imgproc.hpp>

namespace locd::emoi {
namespace {

// A cell centre on the disk's rim counts (rounding of r^2 in metres and in cells alike).
constexpr double kInclusive = 1.0 + 1e-9;

std::string percent(double fraction) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f %%", 100.0 * fraction);
  return text;
}

std::string metres(double value, const char* unit) {
  char text[48];
  std::snprintf(text, sizeof text, "%.3g %s", value, unit);
  return text;
}

// A value v such that the cells >= v hold at least `mass` of the total, and nearly no more: the
// lower edge of the log-spaced bin (kBins over kDecades below the maximum) where the running sum
// from the top reaches it. Cells below the bins' range (max * 1e-12) are left out of the region.
float region_threshold(const cv::Mat_<float>& cells, double mass) {
  constexpr int kBins = 1024;
  constexpr double kDecades = 12.0;
  double high = 0.0;
  cv::minMaxLoc(cells, nullptr, &high);
  if (!(high > 0.0)) return 0.0f;
  const double top = std::log10(high), bins_per_decade = kBins / kDecades;
  std::vector<double> held(kBins, 0.0);
  double total = 0.0;
  for (int r = 0; r < cells.rows; ++r) {
    const float* p = cells.ptr<float>(r);
    for (int c = 0; c < cells.cols; ++c) {
      if (!(p[c] > 0.0f)) continue;
      total += p[c];
      const int bin = static_cast<int>((top - std::log10(static_cast<double>(p[c]))) * bins_per_decade);
      if (bin < kBins) held[std::max(bin, 0)] += p[c];
    }
  }
  double running = 0.0;
  for (int bin = 0; bin < kBins; ++bin) {
    running += held[bin];
    if (running >= mass * total) return static_cast<float>(std::pow(10.0, top - (bin + 1) / bins_per_decade));
  }
  return static_cast<float>(std::pow(10.0, top - kDecades));
}

}  // namespace

std::vector<BeliefMode> belief_modes(const cv::Mat_<float>& mass, const GridGeometry& geometry, double region_mass,
                                     double min_mode_mass) {
  std::vector<BeliefMode> modes;
  if (mass.empty()) return modes;
  const float threshold = region_threshold(mass, region_mass);
  if (!(threshold > 0.0f)) return modes;
  const cv::Mat_<uchar> region = mass >= threshold;
  cv::Mat_<int> labels;
  const int count = cv::connectedComponents(region, labels, 8, CV_32S);
  // Per label: mass, first and second moments.
  std::vector<double> m(count, 0.0), sx(count, 0.0), sy(count, 0.0), sxx(count, 0.0), syy(count, 0.0),
      sxy(count, 0.0);
  for (int r = 0; r < mass.rows; ++r) {
    const int* label = labels.ptr<int>(r);
    const float* p = mass.ptr<float>(r);
    for (int c = 0; c < mass.cols; ++c) {
      if (label[c] == 0) continue;
      const Eigen::Vector2d x = geometry.center_of(r, c);
      const double w = p[c];
      m[label[c]] += w;
      sx[label[c]] += w * x.x();
      sy[label[c]] += w * x.y();
      sxx[label[c]] += w * x.x() * x.x();
      syy[label[c]] += w * x.y() * x.y();
      sxy[label[c]] += w * x.x() * x.y();
    }
  }
  const double cell_variance = geometry.resolution * geometry.resolution / 12.0;
  for (int k = 1; k < count; ++k) {
    if (!(m[k] >= min_mode_mass) || !(m[k] > 0.0)) continue;
    BeliefMode mode;
    mode.mass = m[k];
    mode.mean = Eigen::Vector2d(sx[k], sy[k]) / m[k];
    mode.covariance << sxx[k] / m[k] - mode.mean.x() * mode.mean.x(), sxy[k] / m[k] - mode.mean.x() * mode.mean.y(),
        sxy[k] / m[k] - mode.mean.x() * mode.mean.y(), syy[k] / m[k] - mode.mean.y() * mode.mean.y();
    mode.covariance += Eigen::Matrix2d::Identity() * cell_variance;
    modes.push_back(mode);
  }
  std::sort(modes.begin(), modes.end(), [](const BeliefMode& a, const BeliefMode& b) { return a.mass > b.mass; });
  return modes;
}

double belief_entropy(const cv::Mat_<float>& mass) {
  double entropy = 0.0;
  for (const float v : mass) {
    if (v > 0.0f) entropy -= static_cast<double>(v) * std::log(static_cast<double>(v));
  }
  return entropy;
}

double mass_within(const cv::Mat_<float>& belief, const cv::Rect& nonzero, const GridGeometry& geometry,
                   const Eigen::Vector2d& centre, double radius_m) {
  const double res = geometry.resolution;
  const Eigen::Vector2d local = (centre - geometry.origin) / res;  // in cells, x = column
  const double reach = radius_m / res;
  const int row_low = std::max(nonzero.y, static_cast<int>(std::floor(local.y() - reach)));
  const int row_high = std::min(nonzero.y + nonzero.height - 1, static_cast<int>(std::ceil(local.y() + reach)));
  const int col_low = std::max(nonzero.x, static_cast<int>(std::floor(local.x() - reach)));
  const int col_high = std::min(nonzero.x + nonzero.width - 1, static_cast<int>(std::ceil(local.x() + reach)));
  double held = 0.0;
  for (int r = row_low; r <= row_high; ++r) {
    const float* p = belief.ptr<float>(r);
    for (int c = col_low; c <= col_high; ++c) {
      if ((geometry.center_of(r, c) - centre).squaredNorm() <= radius_m * radius_m * kInclusive) held += p[c];
    }
  }
  return held;
}

cv::Mat_<float> pooled_mass(const cv::Mat_<float>& belief, const cv::Rect& nonzero, const GridGeometry& geometry,
                            int factor, GridGeometry& pooled_geometry) {
  factor = std::max(factor, 1);
  pooled_geometry = geometry;
  pooled_geometry.resolution = geometry.resolution * factor;
  pooled_geometry.width = (geometry.width + factor - 1) / factor;
  pooled_geometry.height = (geometry.height + factor - 1) / factor;
  cv::Mat_<float> pooled(pooled_geometry.height, pooled_geometry.width, 0.0f);
  const int end = nonzero.x + nonzero.width;
  for (int r = nonzero.y; r < nonzero.y + nonzero.height; ++r) {
    const float* p = belief.ptr<float>(r);
    float* out = pooled.ptr<float>(r / factor);
    // Whole pooled cells in one run each (no division per cell).
    for (int c = nonzero.x; c < end;) {
      const int column = c / factor, stop = std::min(end, (column + 1) * factor);
      float sum = 0.0f;
      for (; c < stop; ++c) sum += p[c];
      out[column] += sum;
    }
  }
  return pooled;
}

namespace {

// 1 where a cell centre lies within radius (cells) of the kernel's centre cell.
cv::Mat_<float> disk_kernel(double radius_cells) {
  const int half = static_cast<int>(std::floor(radius_cells * kInclusive));
  cv::Mat_<float> kernel(2 * half + 1, 2 * half + 1, 0.0f);
  for (int r = -half; r <= half; ++r) {
    for (int c = -half; c <= half; ++c) {
      if (r * r + c * c <= radius_cells * radius_cells * kInclusive) kernel(r + half, c + half) = 1.0f;
    }
  }
  return kernel;
}

// Disk sums of `cells` for the candidate centres in `candidates` (clipped to the grid): the
// best one and its sum.
cv::Point best_disk(const cv::Mat_<float>& cells, const cv::Rect& candidates, double radius_cells, double& best) {
  const cv::Mat_<float> kernel = disk_kernel(radius_cells);
  const int half = kernel.rows / 2;
  const cv::Rect all(0, 0, cells.cols, cells.rows);
  const cv::Rect inner = candidates & all;
  best = -1.0;
  cv::Point at = inner.tl();
  if (inner.area() == 0) return at;
  // The candidates and the kernel's reach around them, zero outside the grid.
  const cv::Rect reach(inner.x - half, inner.y - half, inner.width + 2 * half, inner.height + 2 * half);
  cv::Mat_<float> source(reach.size(), 0.0f);
  const cv::Rect inside = reach & all;
  cells(inside).copyTo(source(inside - reach.tl()));
  cv::Mat_<float> sums;
  cv::filter2D(source, sums, CV_32F, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_CONSTANT);
  for (int r = 0; r < inner.height; ++r) {
    const float* s = sums.ptr<float>(r + half);
    for (int c = 0; c < inner.width; ++c) {
      if (s[c + half] > best) {
        best = s[c + half];
        at = cv::Point(inner.x + c, inner.y + r);
      }
    }
  }
  return at;
}

}  // namespace

Eigen::Vector2d disk_maximum(const cv::Mat_<float>& belief, const cv::Rect& nonzero, const GridGeometry& geometry,
                             const cv::Mat_<float>& pooled, const GridGeometry& pooled_geometry, double radius_m,
                             double& mass) {
  // Pooled grid: the best disk there (the radius at least one pooled cell, so neighbours count).
  double coarse_best = 0.0;
  const double coarse_radius = std::max(radius_m / pooled_geometry.resolution, 1.0);
  const cv::Point coarse =
      best_disk(pooled, cv::Rect(0, 0, pooled.cols, pooled.rows), coarse_radius, coarse_best);
  // Belief grid: every centre within the pooled disk's reach of that cell.
  const Eigen::Vector2d centre = pooled_geometry.center_of(coarse.y, coarse.x);
  const double search_m = (coarse_radius + 1.0) * pooled_geometry.resolution;
  const Eigen::Vector2d low = (centre - geometry.origin) / geometry.resolution - Eigen::Vector2d::Constant(search_m / geometry.resolution);
  const int span = static_cast<int>(std::ceil(2.0 * search_m / geometry.resolution)) + 1;
  const cv::Rect candidates = cv::Rect(static_cast<int>(std::floor(low.x())), static_cast<int>(std::floor(low.y())), span, span) & nonzero;
  if (candidates.area() == 0) {
    mass = coarse_best;
    return centre;
  }
  const cv::Point fine = best_disk(belief, candidates, radius_m / geometry.resolution, mass);
  return geometry.center_of(fine.y, fine.x);
}

BeliefAssessment assess_belief(const cv::Mat_<float>& belief, const cv::Rect& nonzero, const GridGeometry& geometry,
                               const AssessmentConfig& config) {
  BeliefAssessment out;
  GridGeometry pooled_geometry;
  const int factor = static_cast<int>(std::lround(config.mode_cell_m / geometry.resolution));
  const cv::Mat_<float> pooled = pooled_mass(belief, nonzero, geometry, factor, pooled_geometry);
  out.modes = belief_modes(pooled, pooled_geometry, config.mode_region_mass, config.min_mode_mass);
  out.entropy_nats = belief_entropy(pooled);
  out.area_m2 = std::exp(out.entropy_nats) * pooled_geometry.resolution * pooled_geometry.resolution;
  out.estimate = disk_maximum(belief, nonzero, geometry, pooled, pooled_geometry, config.tracking_radius_m, out.peak_mass);
  LocalizationAssessment& judged = out.localization;
  if (out.area_m2 > config.lost_area_m2) {
    judged.state = LocalizationState::kLost;
    judged.reason = "belief spread over " + metres(out.area_m2, "m^2") + " (exp(entropy)) > lost_area_m2 " +
                    metres(config.lost_area_m2, "m^2");
  } else if (out.modes.size() > 1) {
    judged.state = LocalizationState::kUncertain;
    judged.reason = std::to_string(out.modes.size()) + " modes (masses " + percent(out.modes[0].mass) + ", " +
                    percent(out.modes[1].mass) + (out.modes.size() > 2 ? ", ..." : "") + ")";
  } else if (out.peak_mass < config.tracking_mass) {
    judged.state = LocalizationState::kUncertain;
    judged.reason = percent(out.peak_mass) + " of the belief within " + metres(config.tracking_radius_m, "m") +
                    " of the estimate < tracking_mass " + percent(config.tracking_mass);
  } else {
    judged.state = LocalizationState::kTracking;
    judged.reason = "one mode, " + percent(out.peak_mass) + " of the belief within " +
                    metres(config.tracking_radius_m, "m") + " of the estimate";
  }
  return out;
}

void apply_fit(BeliefAssessment& assessment, double fit_rms_m, const AssessmentConfig& config) {
  assessment.fit_rms_m = fit_rms_m;
  LocalizationAssessment& judged = assessment.localization;
  if (judged.state != LocalizationState::kTracking) return;
  if (!std::isfinite(fit_rms_m)) {
    judged.state = LocalizationState::kUncertain;
    judged.reason = "one mode, " + percent(assessment.peak_mass) + " of the belief within " +
                    metres(config.tracking_radius_m, "m") +
                    ", not yet checked against the local map's elevations";
  } else if (fit_rms_m > config.max_fit_rms_m) {
    judged.state = LocalizationState::kUncertain;
    judged.reason = "the local map fits the DSM at the estimate to " + metres(fit_rms_m, "m") +
                    " RMS > max_fit_rms_m " + metres(config.max_fit_rms_m, "m");
  } else {
    judged.reason += ", local map fits to " + metres(fit_rms_m, "m") + " RMS";
  }
}

}  // namespace locd::emoi
