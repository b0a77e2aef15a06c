// Grid Markov localization (paper Table 1) over the DSM's cells, with the EMOI similarity of
// eq. 8 as the sensor model. Heading comes from odometry/IMU, so the belief is over (x, y).
//
//  motion:  bel-(x) = shift by the odometry displacement (bilinear, mass-preserving), then a
//           Gaussian blur of standard deviation odometry_error * distance travelled (three box
//           passes for wide kernels: cost independent of the width);
//  sensor:  bel(x) = p(z | x) bel-(x), p(z | x) = prod_R Similarity_R ^ w_R (eq. 8), floored;
//  then the belief is normalised.
// Mass pushed off the map by the motion update is lost and reported, not wrapped around.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "locd/emoi_markov/config.hpp"
#include "locd/emoi_markov/emoi.hpp"
#include "locd/sdk/grid.hpp"

namespace locd::emoi {

// The robot's measurement: its EMOI per radius and how much of each disk it has observed.
struct EmoiObservation {
  std::vector<double> emoi;      // one per radius (normalised EMOI)
  std::vector<double> coverage;  // one per radius, [0, 1]
};

struct MotionUpdateReport {
  double mass_before = 0.0;
  double mass_lost = 0.0;   // pushed off the map (or onto cells without data)
  bool reset = false;       // nothing left: belief reset to uniform
};

struct SensorUpdateReport {
  double evidence = 0.0;    // sum of p(z|x) bel-(x) before normalisation
  bool applied = false;
};

struct BeliefSummary {
  Eigen::Vector2d mode = Eigen::Vector2d::Zero();   // centre of the most probable cell
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();  // about the mode
  double max_probability = 0.0;
  double effective_cells = 0.0;     // 1 / sum p^2: how many cells the belief spreads over
};

// Box widths of `passes` box filters whose composition has standard deviation sigma (cells)
// (W. Wells 1986; P. Kovesi 2010). Odd widths, so every pass is centred.
std::vector<int> box_widths_for_gaussian(double sigma_cells, int passes);

// Weight of one radius from the observed fraction of its disk: 0 below min_coverage, rising
// linearly to 1 at full_coverage (tempers the likelihood when the local map is thin).
double coverage_weight(double coverage, const SensorModelConfig& sensor);

// The paper's sensor model on the precomputed full-disk layers: log p(z|x) =
// -sum_R w_R (EMOI_robot - EMOI_DSM(x))^2 / sigma^2 (eq. 8 multiplied over radii). NaN where a
// layer has no data. weights (out) gets w_R.
cv::Mat_<float> full_disk_log_likelihood(const EmoiLayers& layers, const EmoiObservation& z,
                                         const SensorModelConfig& sensor, std::vector<double>* weights = nullptr);

// Cells where every layer holds a value.
cv::Mat_<uchar> layers_support(const EmoiLayers& layers);

class MarkovGrid {
 public:
  // support: cells the robot may occupy (DSM data there); belief is zero elsewhere.
  MarkovGrid(GridGeometry geometry, cv::Mat_<uchar> support);

  void set_uniform();
  void set_gaussian(const Eigen::Vector2d& mean, double stddev_m);

  MotionUpdateReport motion_update(const Eigen::Vector2d& displacement_m, double blur_stddev_m);
  // bel(x) = p(z|x) bel-(x) with p = exp(max(log_likelihood, log(min_likelihood))); normalised.
  SensorUpdateReport sensor_update(const cv::Mat_<float>& log_likelihood, double min_likelihood);
  // The same with p(z|x) given (already floored, finite, >= 0).
  SensorUpdateReport sensor_update_likelihood(const cv::Mat_<float>& likelihood);
  // The same with p(z|x) = window_likelihood(x - window.tl()) inside `window` and `outside`
  // everywhere else (the sparse sensor model: likelihood evaluated on a window only).
  SensorUpdateReport sensor_update_likelihood(const cv::Mat_<float>& window_likelihood, const cv::Rect& window,
                                              float outside);

  BeliefSummary summary() const;
  const cv::Mat_<float>& belief() const { return belief_; }
  // Every cell outside this rectangle holds zero (a concentrated belief: the updates and the
  // summary run on it alone; a uniform belief: the whole grid).
  const cv::Rect& occupied() const { return occupied_; }
  const GridGeometry& geometry() const { return geometry_; }
  const cv::Mat_<uchar>& support() const { return support_; }

 private:
  // Normalises over occupied_, flushes values below 1e-30 to zero (no denormals) and shrinks
  // occupied_ to the cells left non-zero. Returns the mass before.
  double normalise();
  GridGeometry geometry_;
  cv::Mat_<float> belief_;
  cv::Rect occupied_;
  cv::Mat_<uchar> support_;
  size_t support_cells_ = 0;
  bool full_support_ = false;
};

}  // namespace locd::emoi
