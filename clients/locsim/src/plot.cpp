#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

#include "locd/sim/report.hpp"

namespace locd::sim {

namespace {

const cv::Scalar kBlack(0, 0, 0), kGrey(150, 150, 150), kErrorColour(40, 40, 220), kSigmaColour(200, 120, 0);

cv::Scalar state_colour(LocalizationState s) {
  switch (s) {
    case LocalizationState::kTracking: return {60, 170, 60};
    case LocalizationState::kUncertain: return {0, 165, 255};
    case LocalizationState::kLost: return {40, 40, 220};
    case LocalizationState::kUnknown: break;
  }
  return {200, 200, 200};
}

void text(cv::Mat& image, const std::string& s, cv::Point at, double scale = 0.5, const cv::Scalar& colour = kBlack) {
  cv::putText(image, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

std::string number(double v, int digits) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.*f", digits, v);
  return buffer;
}

// One panel: the signed error (red) against +-3 sigma (blue band edges) over time. The vertical
// range covers 3 sigma and the error up to their 98th percentile, so a kidnap's spike does not
// flatten the rest; values beyond it are drawn at the edge.
void error_panel(cv::Mat& image, const cv::Rect& area, const RunResult& result, const std::string& label,
                 const std::function<double(const ScoredEstimate&)>& error,
                 const std::function<double(const ScoredEstimate&)>& three_sigma, double t_max) {
  std::vector<double> extent;
  for (const auto& e : result.estimates) {
    extent.push_back(std::abs(error(e)));
    if (std::isfinite(three_sigma(e))) extent.push_back(three_sigma(e));
  }
  double y_max = std::max(percentile(extent, 98) * 1.1, 1e-6);
  if (!std::isfinite(y_max)) y_max = 1.0;
  cv::rectangle(image, area, kBlack);
  const int mid = area.y + area.height / 2;
  cv::line(image, {area.x, mid}, {area.x + area.width, mid}, kGrey);
  auto pixel = [&](double t, double v) {
    const double clipped = std::clamp(v, -y_max, y_max);
    return cv::Point(area.x + static_cast<int>(std::lround(area.width * t / t_max)),
                     mid - static_cast<int>(std::lround(0.5 * area.height * clipped / y_max)));
  };
  std::vector<cv::Point> upper, lower, errors;
  for (const auto& e : result.estimates) {
    const double s = std::isfinite(three_sigma(e)) ? three_sigma(e) : y_max;
    upper.push_back(pixel(e.t, s));
    lower.push_back(pixel(e.t, -s));
    errors.push_back(pixel(e.t, error(e)));
  }
  cv::polylines(image, upper, false, kSigmaColour, 1, cv::LINE_AA);
  cv::polylines(image, lower, false, kSigmaColour, 1, cv::LINE_AA);
  cv::polylines(image, errors, false, kErrorColour, 1, cv::LINE_AA);
  text(image, label, {area.x + 5, area.y - 6});
  text(image, "+" + number(y_max, y_max < 0.1 ? 3 : 2), {area.x - 58, area.y + 12}, 0.4);
  text(image, "-" + number(y_max, y_max < 0.1 ? 3 : 2), {area.x - 58, area.y + area.height}, 0.4);
}

// Below the map: x, y and heading error against 3 sigma over time, the plugin's localization state
// as a colour strip, and the kidnap or wrong start as a vertical line.
cv::Mat consistency_panels(const RunResult& result, int width) {
  const int left = 70, right = 20, panel = 150, gap = 34, strip = 16;
  const int height = gap + 3 * (panel + gap) + strip + 60;
  cv::Mat image(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  if (result.estimates.empty()) return image;
  const double t_max = std::max(result.estimates.back().t, 1e-3);
  const int plot_width = width - left - right;
  const auto sigma3 = [](double variance) { return variance > 0 ? 3.0 * std::sqrt(variance) : std::nan(""); };
  int top = gap;
  error_panel(image, {left, top, plot_width, panel}, result, "x error (m, red) and +-3 sigma (blue)",
              [](const ScoredEstimate& e) { return e.estimate.x - e.truth.x; },
              [&](const ScoredEstimate& e) { return sigma3(e.covariance(0, 0)); }, t_max);
  top += panel + gap;
  error_panel(image, {left, top, plot_width, panel}, result, "y error (m) and +-3 sigma",
              [](const ScoredEstimate& e) { return e.estimate.y - e.truth.y; },
              [&](const ScoredEstimate& e) { return sigma3(e.covariance(1, 1)); }, t_max);
  top += panel + gap;
  error_panel(image, {left, top, plot_width, panel}, result, "heading error (deg) and +-3 sigma",
              [](const ScoredEstimate& e) { return normalize_angle(e.estimate.theta - e.truth.theta) * 180.0 / M_PI; },
              [&](const ScoredEstimate& e) { return sigma3(e.covariance(2, 2)) * 180.0 / M_PI; }, t_max);
  top += panel + gap / 2;
  // The state strip: one coloured column per estimate, up to the next.
  for (size_t i = 0; i < result.estimates.size(); ++i) {
    const double t0 = result.estimates[i].t, t1 = i + 1 < result.estimates.size() ? result.estimates[i + 1].t : t_max;
    const int x0 = left + static_cast<int>(plot_width * t0 / t_max), x1 = left + static_cast<int>(plot_width * t1 / t_max);
    cv::rectangle(image, {x0, top}, {std::max(x1, x0 + 1), top + strip}, state_colour(result.estimates[i].state), cv::FILLED);
  }
  text(image, "state", {left - 58, top + 12}, 0.45);
  text(image, "0 s", {left, top + strip + 16}, 0.45);
  text(image, number(t_max, 1) + " s", {left + plot_width - 50, top + strip + 16}, 0.45);
  int x = left + 80;
  for (auto s : {LocalizationState::kTracking, LocalizationState::kUncertain, LocalizationState::kLost,
                 LocalizationState::kUnknown}) {
    cv::rectangle(image, {x, top + strip + 6}, {x + 14, top + strip + 18}, state_colour(s), cv::FILLED);
    text(image, localization_state_name(s), {x + 18, top + strip + 17}, 0.45);
    x += 110;
  }
  const ConsistencySummary& c = result.summary.consistency;
  text(image,
       "position NEES mean " + number(c.nees_position_mean, 2) + ", " + number(100.0 * c.position_inside_95_share, 1) +
           " % inside 95 %; outside the 99 % ellipse " + number(100.0 * c.outside_99_share, 2) + " %, confidently wrong " +
           number(100.0 * c.confidently_wrong_share, 2) + " % (" + c.verdict + ")",
       {left, top + strip + 40}, 0.45);
  if (result.event) {
    const int ex = left + static_cast<int>(plot_width * result.event->t / t_max);
    cv::line(image, {ex, gap}, {ex, top + strip}, {0, 0, 0}, 1, cv::LINE_AA);
    text(image, result.event->kind == "kidnap" ? "kidnap" : "wrong start", {ex + 4, gap + 14}, 0.45);
  }
  return image;
}

}  // namespace

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
  for (size_t i = 0; i < result.truth_path.size(); ++i) {
    const Pose2& p = result.truth_path[i];
    if (i > 0 && std::hypot(p.x - result.truth_path[i - 1].x, p.y - result.truth_path[i - 1].y) > 1.0) {  // a kidnap
      if (truth.size() > 1) cv::polylines(image, truth, false, truth_colour, 2, cv::LINE_AA);
      truth.clear();
    }
    truth.push_back(pixel(p.x, p.y));
  }
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

  const int panels_width = std::max(image.cols, 900);
  if (image.cols < panels_width) {
    cv::copyMakeBorder(image, image, 0, 0, 0, panels_width - image.cols, cv::BORDER_CONSTANT, cv::Scalar(255, 255, 255));
  }
  cv::vconcat(image, consistency_panels(result, panels_width), image);

  bool written = false;
  try {
    written = cv::imwrite(png_file, image);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot write plot '" + png_file + "': " + e.what());
  }
  if (!written) throw std::runtime_error("cannot write plot '" + png_file + "'");
}

}  // namespace locd::sim
