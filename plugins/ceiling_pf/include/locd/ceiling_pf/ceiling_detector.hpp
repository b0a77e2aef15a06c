// The paper's image pipeline (Fig. 1): Gaussian blur, threshold, Hough circle transform, then
// each circle's centre through the camera model (eq. 1-3) to a ceiling point in base_link.
// Beyond the paper, for speed and precision: the Hough transform may run on a pyramid level
// (each level halves the image), and each circle's centre is then refined to the centroid of
// its thresholded disk at full resolution.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "locd/ceiling_pf/ceiling_camera.hpp"

namespace locd::ceiling_pf {

struct DetectorConfig {
  int blur_kernel = 5;              // odd, pixels
  double blur_sigma = 1.5;          // pixels
  double threshold = 170.0;         // grey level; brighter pixels are landmark candidates
  double hough_dp = 1.0;            // accumulator resolution = image resolution / dp
  double min_distance_px = 20.0;    // between circle centres
  double canny_threshold = 100.0;   // upper Canny threshold inside HoughCircles
  double accumulator_threshold = 10.0;  // at the Hough level
  int min_radius_px = 12;
  int max_radius_px = 22;
  int max_circles = 32;             // more circles in one frame are cut (strongest first)
  int pyramid_levels = 1;           // Hough on the image halved this many times (radii in full-res px)
  bool refine_centroid = true;      // centre = centroid of the full-resolution disk
};

struct CircleDetection {
  double column = 0.0, row = 0.0, radius_px = 0.0;
};

class CeilingDetector {
 public:
  explicit CeilingDetector(const DetectorConfig& config);

  // Circles in an 8-bit mono image (CV_8UC1). Reuses internal buffers: not thread-safe.
  const std::vector<CircleDetection>& detect(const cv::Mat& mono);
  // Circle centres as ceiling points in base_link.
  std::vector<Eigen::Vector2d> detect_points(const cv::Mat& mono, const CeilingCamera& camera);

  const DetectorConfig& config() const { return config_; }
  const cv::Mat& binary() const { return binary_; }

 private:
  void refine(CircleDetection& detection) const;

  DetectorConfig config_;
  cv::Mat blurred_, binary_, small_, small_binary_;
  std::vector<cv::Vec3f> circles_;
  std::vector<CircleDetection> detections_;
};

}  // namespace locd::ceiling_pf
