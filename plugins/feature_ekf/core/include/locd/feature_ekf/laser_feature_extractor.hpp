// Turns an ordered 2D scan into the paper's features (sec. 2.2) in the robot frame (base_link):
// lines (r, phi) with a covariance from the point noise, corners (range, bearing) where adjacent
// lines meet, edges (range, bearing) at occluding segment ends.
//
// Method (beyond the paper, which does not say how it extracts): points of valid returns in beam
// order are cut into clusters at gaps; each cluster is split and merged (iterative end-point fit,
// then adjacent pieces merged while one total-least-squares line still fits them); every piece is
// fitted by total least squares.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "locd/feature_ekf/config.hpp"
#include "locd/sdk/types.hpp"

namespace locd::feature_ekf {

struct ExtractedLine {
  Eigen::Vector2d z = Eigen::Vector2d::Zero();  // (r, phi): distance to the line, normal direction
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
  Eigen::Vector2d start = Eigen::Vector2d::Zero();  // end points on the fitted line, robot frame
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
  size_t first_beam = 0, last_beam = 0;
  int points = 0;
};

struct ExtractedPoint {
  Eigen::Vector2d z = Eigen::Vector2d::Zero();  // (range, bearing)
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  // robot frame
};

struct ExtractedFeatures {
  std::vector<ExtractedLine> lines;
  std::vector<ExtractedPoint> corners;
  std::vector<ExtractedPoint> edges;
  size_t usable_returns = 0;
};

// Total-least-squares line through points (normal form r >= 0) with its covariance for
// isotropic point noise sigma^2: var(phi) = sigma^2 / sum(s_i^2), var(r) = sigma^2 / n +
// (c.t)^2 var(phi), cov(r, phi) = (c.t) var(phi), c the centroid, t = (-sin phi, cos phi),
// s_i the positions along the line.
struct LineFit {
  Eigen::Vector2d z = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
  double max_residual = 0.0;
};
LineFit fit_line(const std::vector<Eigen::Vector2d>& points, size_t first, size_t last, double point_stddev);

class LaserFeatureExtractor {
 public:
  explicit LaserFeatureExtractor(ExtractorConfig config = {}) : config_(config) {}
  ExtractedFeatures extract(const LaserScan& scan) const;
  const ExtractorConfig& config() const { return config_; }

 private:
  ExtractorConfig config_;
};

}  // namespace locd::feature_ekf
