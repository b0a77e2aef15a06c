// Beyond the paper: the local elevation map and the motion update share one unknown, the
// distortion of the odometry since the last sensor update. Odometry with a scale error s and a
// direction error d reports a displacement s R(d) times the true one; the local map is placed
// with it, so a cell seen D metres back sits (s R(d) - I) D off, and the belief moved by the
// same distorted displacement. Both are marginalised together over a grid of hypotheses B (the
// true displacement is B times the odometry's):
//
//   bel'(x) ∝ sum_B p(B) prior_B(x) L_B(x)
//           = prior(x) * L_mix(x),  L_mix(x) = sum_B p(B) prior_B(x) L_B(x) / sum_B p(B) prior_B(x)
//
// where prior_B is the previous belief shifted by B * odometry shift and blurred by what the
// grid does not cover, and L_B the likelihood of the local map rebuilt under B. prior(x) is the
// usual shift-plus-blur motion update (Table 1), so L_mix replaces the likelihood where the
// prior holds its mass, and each hypothesis' likelihood counts where its own shift puts the robot.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include "locd/emoi_markov/config.hpp"
#include "locd/emoi_markov/masked_emoi.hpp"

namespace locd::emoi {

struct DistortionHypothesis {
  Eigen::Matrix2d transform = Eigen::Matrix2d::Identity();  // B = scale * R(direction)
  double scale = 1.0;
  double direction_rad = 0.0;
  double weight = 1.0;                                       // p(B); the grid's weights sum to one
};

// nodes x nodes hypotheses: scale 1 + u scale_stddev, direction u direction_stddev_rad, u on an
// even grid over [-2, 2] standard deviations, weights from the Gaussian, normalised. nodes = 1
// gives the identity alone.
std::vector<DistortionHypothesis> distortion_hypotheses(double scale_stddev, double direction_stddev_rad, int nodes);

// Variance (in standard deviations squared, per axis) the hypothesis grid already spreads:
// sum w u^2 over the nodes of one axis. The motion blur left to each hypothesis is the rest.
double distortion_grid_variance(int nodes);

// L_mix at the listed matching-grid cells (x = column, y = row).
//   previous: the belief before the motion update, pooled to the matching grid (mass per cell)
//   shift_cells: the odometry shift since the last update, in matching cells (x = columns)
//   residual_blur_cells: the blur each hypothesis' prior gets after its shift
//   likelihoods[b][i]: L_B of hypothesis b at cell i
// Where no hypothesis' prior reaches a cell, the weighted mean over the hypotheses is returned.
std::vector<float> mixture_likelihood(const cv::Mat_<float>& previous, const Eigen::Vector2d& shift_cells,
                                      const std::vector<DistortionHypothesis>& hypotheses, double residual_blur_cells,
                                      const std::vector<cv::Point>& cells,
                                      const std::vector<std::vector<float>>& likelihoods,
                                      std::vector<double>* hypothesis_posterior = nullptr);

// The matching-grid cells holding at least `mass` of a belief (largest first), or an empty list
// when more than max_cells would be needed.
std::vector<cv::Point> cells_holding_mass(const cv::Mat_<float>& belief, double mass, size_t max_cells);

// The blur each hypothesis' prior keeps: what the grid does not spread of the motion blur
// (blur_m for travel_m), at least half the grid's spacing (neighbouring hypotheses overlap) and
// at least min_blur_m.
double residual_blur_m(const DistortionConfig& config, double blur_m, double travel_m, double min_blur_m);

struct DistortionReport {
  size_t cells = 0;                     // matching cells L_mix replaced the likelihood on (0: not run)
  double scale = 1.0;                   // posterior mean of the hypotheses
  double direction_rad = 0.0;
  std::vector<double> posterior;        // per hypothesis, sums to one
};

// The sparse sensor model once the prior is concentrated: L_mix (floored at
// sensor.min_likelihood) by direct sums on the matching cells holding support_mass of the prior
// (at most max_cells of them), and nothing computed anywhere else. Every other cell gets one
// likelihood, `outside`: the smallest on the support. They hold less than 1 - support_mass of
// the prior, so whatever they would get moves at most that much mass; with the smallest support
// value they can neither take over the posterior nor be wiped out by the floor.
struct SupportLikelihood {
  std::vector<cv::Point> cells;          // the support, matching grid (x = column); empty: prior too spread
  std::vector<float> likelihood;         // L_mix per support cell, floored
  std::vector<float> best_shape_residual;  // per support cell, the smallest over the hypotheses (m^2; NaN:
                                           // no overlap; empty without the shape term)
  float outside = 0.0f;                  // every other cell's likelihood
  MaskedEmoiMatcher::Match identity;     // the match of the local map as odometry placed it (B = I), at the cells
  std::vector<double> weights;           // its per-radius weights (coverage_weight)
  DistortionReport report;
};
SupportLikelihood support_likelihood(const MaskedEmoiMatcher& matcher,
                                     const std::function<cv::Mat_<float>(const Eigen::Matrix2d&)>& patch_under,
                                     const std::vector<DistortionHypothesis>& hypotheses,
                                     const DistortionConfig& config, const SensorModelConfig& sensor,
                                     const cv::Mat_<float>& previous, const cv::Mat_<float>& prior,
                                     const Eigen::Vector2d& shift_m, double residual_blur_m);

// The sparse likelihood on the DSM (belief) grid: returned on fine_rect (out), the support's
// bounding box (and a margin, so the bilinear interpolation sees `outside` around it); every
// other cell of the belief grid gets sparse.outside.
cv::Mat_<float> support_likelihood_on_grid(const MaskedEmoiMatcher& matcher, const SupportLikelihood& sparse,
                                           int fine_rows, int fine_cols, cv::Rect& fine_rect);

// The dense form, the reference of the sparse one: the sensor model of the masked match with the
// odometry's distortion marginalised:
//   likelihood: on entry exp(log p(z|x)) of the local map as odometry placed it, on the matching
//     grid; on return L_mix (floored at sensor.min_likelihood) on the cells where the prior
//     (after the motion update, pooled to the matching grid) holds support_mass, if that takes at
//     most max_cells cells; elsewhere unchanged.
//   previous: the belief before the motion update, pooled to the matching grid
//   shift_m: the odometry shift since the last update (map frame); patch_under(B): the robot's
//     patch with the local map rebuilt under B.
DistortionReport apply_distortion_hypotheses(const MaskedEmoiMatcher& matcher,
                                             const std::function<cv::Mat_<float>(const Eigen::Matrix2d&)>& patch_under,
                                             const std::vector<DistortionHypothesis>& hypotheses,
                                             const DistortionConfig& config, const SensorModelConfig& sensor,
                                             const cv::Mat_<float>& previous, const cv::Mat_<float>& prior,
                                             const Eigen::Vector2d& shift_m, double residual_blur_m,
                                             cv::Mat_<float>& likelihood);

}  // namespace locd::emoi
