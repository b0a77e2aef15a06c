#include "locd/ceiling_pf/ceiling_detector.hpp"

#include <opencv2/imgproc.hpp>
#include <cmath>
#include <string>

#include "locd/sdk/errors.hpp"

namespace locd::ceiling_pf {

CeilingDetector::CeilingDetector(const DetectorConfig& config) : config_(config) {
  if (config_.blur_kernel < 1 || config_.blur_kernel % 2 == 0) {
    throw ConfigError("ceiling_pf: blur kernel " + std::to_string(config_.blur_kernel) + " must be odd and positive");
  }
}

const std::vector<CircleDetection>& CeilingDetector::detect(const cv::Mat& mono) {
  if (mono.type() != CV_8UC1) throw InputError("ceiling_pf: the detector expects an 8-bit mono image (mono8)");
  const int k = config_.blur_kernel;
  cv::GaussianBlur(mono, blurred_, cv::Size(k, k), config_.blur_sigma);
  cv::threshold(blurred_, binary_, config_.threshold, 255.0, cv::THRESH_BINARY);
  const cv::Mat* hough_input = &binary_;
  const double scale = static_cast<double>(1 << config_.pyramid_levels);
  if (config_.pyramid_levels > 0) {
    cv::pyrDown(blurred_, small_);
    for (int level = 1; level < config_.pyramid_levels; ++level) cv::pyrDown(small_, small_);
    cv::threshold(small_, small_binary_, config_.threshold, 255.0, cv::THRESH_BINARY);
    hough_input = &small_binary_;
  }
  circles_.clear();
  cv::HoughCircles(*hough_input, circles_, cv::HOUGH_GRADIENT, config_.hough_dp, config_.min_distance_px / scale,
                   config_.canny_threshold, config_.accumulator_threshold,
                   std::max(1, static_cast<int>(std::floor(config_.min_radius_px / scale))),
                   std::max(1, static_cast<int>(std::ceil(config_.max_radius_px / scale))));
  detections_.clear();
  // pyrDown centres level pixel j on full-resolution pixel 2j.
  for (const cv::Vec3f& c : circles_) {
    if (static_cast<int>(detections_.size()) >= config_.max_circles) break;
    CircleDetection d{c[0] * scale, c[1] * scale, c[2] * scale};
    if (d.radius_px < config_.min_radius_px - scale || d.radius_px > config_.max_radius_px + scale) continue;
    if (config_.refine_centroid) refine(d);
    detections_.push_back(d);
  }
  return detections_;
}

void CeilingDetector::refine(CircleDetection& d) const {
  const int reach = static_cast<int>(std::ceil(d.radius_px * 1.3)) + 2;
  const cv::Rect window = cv::Rect(static_cast<int>(std::lround(d.column)) - reach, static_cast<int>(std::lround(d.row)) - reach,
                                   2 * reach + 1, 2 * reach + 1) &
                          cv::Rect(0, 0, binary_.cols, binary_.rows);
  if (window.empty()) return;
  const cv::Moments m = cv::moments(binary_(window), true);
  if (m.m00 < 0.5 * M_PI * config_.min_radius_px * config_.min_radius_px) return;
  const double column = window.x + m.m10 / m.m00, row = window.y + m.m01 / m.m00;
  // A disk cut by the window (another blob, the image border) would pull the centroid: keep
  // the Hough centre then.
  if (std::hypot(column - d.column, row - d.row) > 0.5 * d.radius_px) return;
  d.column = column;
  d.row = row;
  d.radius_px = std::sqrt(m.m00 / M_PI);
}

std::vector<Eigen::Vector2d> CeilingDetector::detect_points(const cv::Mat& mono, const CeilingCamera& camera) {
  std::vector<Eigen::Vector2d> points;
  for (const CircleDetection& c : detect(mono)) points.push_back(camera.ceiling_point_in_base(c.column, c.row));
  return points;
}

}  // namespace locd::ceiling_pf
