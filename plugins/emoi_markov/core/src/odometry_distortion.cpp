#include "locd/emoi_markov/odometry_distortion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "locd/sdk/errors.hpp"

namespace locd::emoi {
namespace {
std::vector<double> grid_nodes(int nodes) {
  std::vector<double> u;
  for (int k = 0; k < nodes; ++k) u.push_back(nodes == 1 ? 0.0 : -2.0 + 4.0 * k / (nodes - 1));
  return u;
}
}  // namespace

std::vector<DistortionHypothesis> distortion_hypotheses(double scale_stddev, double direction_stddev_rad, int nodes) {
  if (nodes < 1 || nodes % 2 == 0) throw ConfigError("distortion grid needs an odd number of nodes per axis");
  const std::vector<double> u = grid_nodes(nodes);
  std::vector<DistortionHypothesis> out;
  double total = 0.0;
  for (double us : u) {
    for (double ud : u) {
      DistortionHypothesis h;
      h.scale = 1.0 + us * scale_stddev;
      h.direction_rad = ud * direction_stddev_rad;
      h.transform = h.scale * Eigen::Rotation2Dd(h.direction_rad).toRotationMatrix();
      h.weight = std::exp(-0.5 * (us * us + ud * ud));
      total += h.weight;
      out.push_back(h);
    }
  }
  for (auto& h : out) h.weight /= total;
  return out;
}

double distortion_grid_variance(int nodes) {
  double weights = 0.0, moment = 0.0;
  for (double u : grid_nodes(nodes)) {
    const double w = std::exp(-0.5 * u * u);
    weights += w;
    moment += w * u * u;
  }
  return moment / weights;
}

std::vector<float> mixture_likelihood(const cv::Mat_<float>& previous, const Eigen::Vector2d& shift_cells,
                                      const std::vector<DistortionHypothesis>& hypotheses, double residual_blur_cells,
                                      const std::vector<cv::Point>& cells,
                                      const std::vector<std::vector<float>>& likelihoods,
                                      std::vector<double>* hypothesis_posterior) {
  if (likelihoods.size() != hypotheses.size()) throw InputError("one likelihood list per distortion hypothesis");
  for (const auto& l : likelihoods) {
    if (l.size() != cells.size()) throw InputError("one likelihood per cell and hypothesis");
  }
  std::vector<float> out(cells.size(), 0.0f);
  if (cells.empty()) return out;
  cv::Rect window(cells[0], cv::Size(1, 1));
  for (const cv::Point& p : cells) window |= cv::Rect(p, cv::Size(1, 1));
  const int margin = residual_blur_cells > 0.3 ? static_cast<int>(std::ceil(3.0 * residual_blur_cells)) + 1 : 1;
  const cv::Size padded(window.width + 2 * margin, window.height + 2 * margin);
  std::vector<double> numerator(cells.size(), 0.0), denominator(cells.size(), 0.0), mean(cells.size(), 0.0);
  std::vector<double> evidence(hypotheses.size(), 0.0);
  for (size_t b = 0; b < hypotheses.size(); ++b) {
    // prior_B(x) = previous(x - B shift), blurred; computed on the cells' window only.
    const Eigen::Vector2d t = hypotheses[b].transform * shift_cells;
    const cv::Matx23d move(1, 0, t.x() - (window.x - margin), 0, 1, t.y() - (window.y - margin));
    cv::Mat_<float> prior;
    cv::warpAffine(previous, prior, move, padded, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0.0);
    if (residual_blur_cells > 0.3) {
      const int half = static_cast<int>(std::ceil(3.0 * residual_blur_cells));
      cv::GaussianBlur(prior, prior, cv::Size(2 * half + 1, 2 * half + 1), residual_blur_cells, residual_blur_cells,
                       cv::BORDER_CONSTANT);
    }
    const double w = hypotheses[b].weight;
    for (size_t i = 0; i < cells.size(); ++i) {
      const double p = w * prior(cells[i].y - window.y + margin, cells[i].x - window.x + margin);
      const double l = likelihoods[b][i];
      numerator[i] += p * l;
      denominator[i] += p;
      mean[i] += w * l;
      evidence[b] += p * l;
    }
  }
  for (size_t i = 0; i < cells.size(); ++i) {
    out[i] = static_cast<float>(denominator[i] > 1e-30 ? numerator[i] / denominator[i] : mean[i]);
  }
  if (hypothesis_posterior) {
    const double total = std::accumulate(evidence.begin(), evidence.end(), 0.0);
    hypothesis_posterior->assign(hypotheses.size(), 0.0);
    for (size_t b = 0; b < hypotheses.size() && total > 0; ++b) (*hypothesis_posterior)[b] = evidence[b] / total;
  }
  return out;
}

std::vector<cv::Point> cells_holding_mass(const cv::Mat_<float>& belief, double mass, size_t max_cells) {
  std::vector<std::pair<float, int>> values;
  double total = 0.0;
  for (int r = 0; r < belief.rows; ++r) {
    const float* b = belief.ptr<float>(r);
    for (int c = 0; c < belief.cols; ++c) {
      if (b[c] > 0.0f) {
        values.emplace_back(b[c], r * belief.cols + c);
        total += b[c];
      }
    }
  }
  if (!(total > 0.0)) return {};
  const size_t keep = std::min(values.size(), max_cells + 1);
  std::partial_sort(values.begin(), values.begin() + static_cast<long>(keep), values.end(),
                    [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<cv::Point> out;
  double held = 0.0;
  for (size_t i = 0; i < keep; ++i) {
    if (out.size() >= max_cells) return {};
    out.emplace_back(values[i].second % belief.cols, values[i].second / belief.cols);
    held += values[i].first;
    if (held >= mass * total) return out;
  }
  return out.size() == values.size() ? out : std::vector<cv::Point>{};
}

double residual_blur_m(const DistortionConfig& config, double blur_m, double travel_m, double min_blur_m) {
  if (config.nodes <= 1) return blur_m;
  const double error = std::max(config.scale_stddev, config.direction_stddev_rad);
  const double spread2 = distortion_grid_variance(config.nodes) * error * error * travel_m * travel_m;
  const double spacing = 4.0 / (config.nodes - 1) * error * travel_m;
  return std::max({std::sqrt(std::max(blur_m * blur_m - spread2, 0.0)), 0.5 * spacing, min_blur_m});
}

SupportLikelihood support_likelihood(const MaskedEmoiMatcher& matcher,
                                     const std::function<cv::Mat_<float>(const Eigen::Matrix2d&)>& patch_under,
                                     const std::vector<DistortionHypothesis>& hypotheses,
                                     const DistortionConfig& config, const SensorModelConfig& sensor,
                                     const cv::Mat_<float>& previous, const cv::Mat_<float>& prior,
                                     const Eigen::Vector2d& shift_m, double residual_blur_m) {
  SupportLikelihood out;
  if (hypotheses.size() <= 1) return out;
  out.cells = cells_holding_mass(prior, config.support_mass, config.max_cells);
  if (out.cells.empty()) return out;
  std::vector<std::vector<float>> likelihoods;
  bool identity_seen = false;
  for (const DistortionHypothesis& h : hypotheses) {
    MaskedEmoiMatcher::Match match = matcher.match_at(patch_under(h.transform), out.cells, sensor.shape_sigma_m > 0.0);
    if (!match.shape_residual.empty()) {
      if (out.best_shape_residual.empty()) {
        out.best_shape_residual.assign(out.cells.size(), std::numeric_limits<float>::quiet_NaN());
      }
      for (size_t i = 0; i < out.cells.size(); ++i) {
        const float r = match.shape_residual(0, static_cast<int>(i));
        if (std::isfinite(r) && !(out.best_shape_residual[i] <= r)) out.best_shape_residual[i] = r;
      }
    }
    const bool identity = !identity_seen && h.transform.isApprox(Eigen::Matrix2d::Identity(), 1e-12);
    cv::Mat_<float> l = matcher.coarse_log_likelihood(match, sensor, identity ? &out.weights : nullptr);
    cv::exp(l, l);
    likelihoods.emplace_back(l.begin(), l.end());
    if (identity) {
      out.identity = std::move(match);
      identity_seen = true;
    }
  }
  if (!identity_seen) {
    out.identity = matcher.match_at(patch_under(Eigen::Matrix2d::Identity()), out.cells);
    matcher.coarse_log_likelihood(out.identity, sensor, &out.weights);
  }
  out.likelihood = mixture_likelihood(previous, shift_m / matcher.cell_m(), hypotheses,
                                      residual_blur_m / matcher.cell_m(), out.cells, likelihoods,
                                      &out.report.posterior);
  const float floor = static_cast<float>(sensor.min_likelihood);
  out.outside = std::numeric_limits<float>::max();
  for (float& l : out.likelihood) {
    l = std::max(l, floor);
    out.outside = std::min(out.outside, l);
  }
  DistortionReport& report = out.report;
  report.cells = out.cells.size();
  report.scale = report.direction_rad = 0.0;
  for (size_t b = 0; b < hypotheses.size(); ++b) {
    report.scale += report.posterior[b] * hypotheses[b].scale;
    report.direction_rad += report.posterior[b] * hypotheses[b].direction_rad;
  }
  return out;
}

cv::Mat_<float> support_likelihood_on_grid(const MaskedEmoiMatcher& matcher, const SupportLikelihood& sparse,
                                           int fine_rows, int fine_cols, cv::Rect& fine_rect) {
  if (sparse.cells.empty()) throw InputError("sparse likelihood without support cells");
  cv::Rect bounds(sparse.cells[0], cv::Size(1, 1));
  for (const cv::Point& p : sparse.cells) bounds |= cv::Rect(p, cv::Size(1, 1));
  const ElevationMap& surface = matcher.surface();
  bounds = cv::Rect(bounds.x - 2, bounds.y - 2, bounds.width + 4, bounds.height + 4) &
           cv::Rect(0, 0, surface.geometry.width, surface.geometry.height);
  cv::Mat_<float> window(bounds.size(), sparse.outside);
  for (size_t i = 0; i < sparse.cells.size(); ++i) window(sparse.cells[i] - bounds.tl()) = sparse.likelihood[i];
  return matcher.to_fine_window(window, bounds, fine_rows, fine_cols, fine_rect);
}

DistortionReport apply_distortion_hypotheses(const MaskedEmoiMatcher& matcher,
                                             const std::function<cv::Mat_<float>(const Eigen::Matrix2d&)>& patch_under,
                                             const std::vector<DistortionHypothesis>& hypotheses,
                                             const DistortionConfig& config, const SensorModelConfig& sensor,
                                             const cv::Mat_<float>& previous, const cv::Mat_<float>& prior,
                                             const Eigen::Vector2d& shift_m, double residual_blur_m,
                                             cv::Mat_<float>& likelihood) {
  const SupportLikelihood sparse =
      support_likelihood(matcher, patch_under, hypotheses, config, sensor, previous, prior, shift_m, residual_blur_m);
  for (size_t i = 0; i < sparse.cells.size(); ++i) likelihood(sparse.cells[i].y, sparse.cells[i].x) = sparse.likelihood[i];
  return sparse.report;
}

}  // namespace locd::emoi
