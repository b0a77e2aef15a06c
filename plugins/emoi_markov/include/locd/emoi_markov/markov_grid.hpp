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

#include "locd/emoi_markov/emoi.hpp"
#include "locd/sdk/grid.hpp"

namespace locd::emoi {

struct SensorModelConfig {
  double sigma_m = 0.05;            // eq. 8 sigma on the normalised EMOI
  double min_likelihood = 1e-6;     // floor of p(z | x): one bad match never zeroes a cell
  double min_coverage = 0.3;        // a radius with a thinner local map is left out
  double full_coverage = 0.9;       // from here on a radius gets its full weight
};

// The robot's measurement: its EMOI per radius and how much of each disk it has observed.
struct EmoiObservation {
  std::vector<double> emoi;      // one per radius (normalised EMOI)
  std::vector<double> coverage;  // one per radius, [0, 1]
};

struct MotionUpdateReport {
  double mass_before = 0.0;
  double mass_lost = 0.0;   // pushed off the map (or onto nodata cells)
  bool reset = false;       // nothing left: belief reset to uniform
};

struct SensorUpdateReport {
  double evidence = 0.0;           // sum of p(z|x) bel-(x) before normalisation
  std::vector<double> weights;     // w_R used (0 = radius left out)
  bool applied = false;            // false when every radius was left out
};

struct BeliefSummary {
  Eigen::Vector2d mode = Eigen::Vector2d::Zero();   // centre of the most probable cell
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();  // about the mode
  double max_probability = 0.0;
  double entropy = 0.0;             // nats
};

// Box widths of `passes` box filters whose composition has standard deviation sigma (cells)
// (W. Wells 1986; P. Kovesi 2010). Odd widths, so every pass is centred.
std::vector<int> box_widths_for_gaussian(double sigma_cells, int passes);

class MarkovGrid {
 public:
  MarkovGrid(GridGeometry geometry, EmoiLayers layers, SensorModelConfig sensor);

  void set_uniform();
  void set_gaussian(const Eigen::Vector2d& mean, double stddev_m);

  MotionUpdateReport motion_update(const Eigen::Vector2d& displacement_m, double blur_stddev_m);
  // The likelihood of eq. 8 for every cell (exposed for tests and diagnostics).
  cv::Mat_<float> likelihood(const EmoiObservation& z, std::vector<double>* weights = nullptr) const;
  SensorUpdateReport sensor_update(const EmoiObservation& z);

  BeliefSummary summary() const;
  const cv::Mat_<float>& belief() const { return belief_; }
  cv::Mat_<float>& belief() { return belief_; }
  const GridGeometry& geometry() const { return geometry_; }
  const EmoiLayers& layers() const { return layers_; }
  const cv::Mat_<uchar>& support() const { return support_; }  // cells with every layer

 private:
  double normalise();
  GridGeometry geometry_;
  EmoiLayers layers_;
  SensorModelConfig sensor_;
  cv::Mat_<float> belief_;
  cv::Mat_<uchar> support_;
  size_t support_cells_ = 0;
};

}  // namespace locd::emoi
