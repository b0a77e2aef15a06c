#include "locd/ceiling_pf/ceiling_detector.hpp"

#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace locd::ceiling_pf {

CeilingDetector::CeilingDetector(const DetectorConfig& config) : config_(config) {
  if (config_.blur_kernel < 1 || config_.blur_kernel % 2 == 0) {
    throw std::invalid_argument("blur kernel must be odd and positive");
  }
}

const std::vector<CircleDetection>& CeilingDetector::detect(const cv::Mat& mono) {
  if (mono.type() != CV_8UC1) throw std::invalid_argument("CeilingDetector expects an 8-bit mono image");
  const int k = config_.blur_kernel;
  cv::GaussianBlur(mono, blurred_, cv::Size(k, k), config_.blur_sigma);
  cv::threshold(blurred_, binary_, config_.threshold, 255.0, cv::THRESH_BINARY);
  circles_.clear();
  cv::HoughCircles(binary_, circles_, cv::HOUGH_GRADIENT, config_.hough_dp, config_.min_distance_px,
                   config_.canny_threshold, config_.accumulator_threshold, config_.min_radius_px,
                   config_.max_radius_px);
  detections_.clear();
  for (const cv::Vec3f& c : circles_) {
    if (static_cast<int>(detections_.size()) >= config_.max_circles) break;
    detections_.push_back({c[0], c[1], c[2]});
  }
  return detections_;
}

std::vector<Eigen::Vector2d> CeilingDetector::detect_points(const cv::Mat& mono, const CeilingCamera& camera) {
  std::vector<Eigen::Vector2d> points;
  for (const CircleDetection& c : detect(mono)) points.push_back(camera.ceiling_point_in_base(c.column, c.row));
  return points;
}

}  // namespace locd::ceiling_pf
