#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "locd/sim/report.hpp"

namespace locd::sim {

void plot_run(const std::string& png_file, const FeatureMap2D& map, const RunResult& result) {
  Eigen::AlignedBox2d box;
  for (const auto& l : map.lines) {
    box.extend(l.a);
    box.extend(l.b);
  }
  for (const auto& p : result.truth_path) box.extend(Eigen::Vector2d(p.x, p.y));
  if (box.isEmpty()) throw std::runtime_error("plot: nothing to draw");
  const double pixels_per_metre = std::min(30.0, 1600.0 / std::max(box.sizes().maxCoeff(), 1.0));
  const int margin = 40, legend_height = 70;
  const int width = static_cast<int>(box.sizes().x() * pixels_per_metre) + 2 * margin;
  const int height = static_cast<int>(box.sizes().y() * pixels_per_metre) + 2 * margin + legend_height;
  cv::Mat image(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  auto pixel = [&](double x, double y) {
    return cv::Point(static_cast<int>(std::lround(margin + (x - box.min().x()) * pixels_per_metre)),
                     static_cast<int>(std::lround(margin + (box.max().y() - y) * pixels_per_metre)));
  };
  for (const auto& l : map.lines) cv::line(image, pixel(l.a.x(), l.a.y()), pixel(l.b.x(), l.b.y()), {0, 0, 0}, 2, cv::LINE_AA);

  const cv::Scalar truth_colour(40, 160, 40), estimate_colour(40, 40, 220);
  std::vector<cv::Point> truth, estimate;
  for (const auto& p : result.truth_path) truth.push_back(pixel(p.x, p.y));
  for (const auto& e : result.estimates) estimate.push_back(pixel(e.estimate.x, e.estimate.y));
  if (truth.size() > 1) cv::polylines(image, truth, false, truth_colour, 2, cv::LINE_AA);
  if (estimate.size() > 1) cv::polylines(image, estimate, false, estimate_colour, 1, cv::LINE_AA);
  if (!result.truth_path.empty()) {
    const Pose2& s = result.truth_path.front();
    cv::circle(image, pixel(s.x, s.y), 7, {200, 100, 0}, 2, cv::LINE_AA);
    cv::arrowedLine(image, pixel(s.x, s.y), pixel(s.x + std::cos(s.theta), s.y + std::sin(s.theta)), {200, 100, 0}, 2,
                    cv::LINE_AA, 0, 0.3);
  }

  // Scale bar (5 m) and legend under the map.
  const int base = height - legend_height + 20;
  const int bar = static_cast<int>(5.0 * pixels_per_metre);
  cv::line(image, {margin, base}, {margin + bar, base}, {0, 0, 0}, 3);
  cv::line(image, {margin, base - 6}, {margin, base + 6}, {0, 0, 0}, 2);
  cv::line(image, {margin + bar, base - 6}, {margin + bar, base + 6}, {0, 0, 0}, 2);
  cv::putText(image, "5 m", {margin + bar / 2 - 15, base + 25}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {0, 0, 0}, 1, cv::LINE_AA);
  int x = margin + bar + 40;
  auto legend = [&](const cv::Scalar& colour, const std::string& text) {
    cv::line(image, {x, base}, {x + 30, base}, colour, 3, cv::LINE_AA);
    cv::putText(image, text, {x + 38, base + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.55, {0, 0, 0}, 1, cv::LINE_AA);
    x += 50 + static_cast<int>(text.size()) * 11;
  };
  legend({0, 0, 0}, "walls");
  legend(truth_colour, "truth");
  legend(estimate_colour, "estimate (" + result.plugin + ")");
  cv::circle(image, {x + 10, base}, 7, {200, 100, 0}, 2, cv::LINE_AA);
  cv::putText(image, "start", {x + 25, base + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.55, {0, 0, 0}, 1, cv::LINE_AA);
  char title[200];
  std::snprintf(title, sizeof(title), "%s  robot %s  rmse %.3f m  p95 %.3f m", result.scenario.c_str(),
                result.robot_id.c_str(), result.summary.rmse_m, result.summary.p95_error_m);
  cv::putText(image, title, {margin, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {0, 0, 0}, 1, cv::LINE_AA);

  bool written = false;
  try {
    written = cv::imwrite(png_file, image);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot write plot '" + png_file + "': " + e.what());
  }
  if (!written) throw std::runtime_error("cannot write plot '" + png_file + "'");
}

}  // namespace locd::sim
