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
#include "locd/ceiling_pf/config.hpp"

namespace locd::ceiling_pf {

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
