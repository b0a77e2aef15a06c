// Markov grid (Table 1): motion update mass and moments, sensor model (eq. 8) and normalisation,
// the masked EMOI match against the direct formula.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "locd/emoi_markov/markov_grid.hpp"
#include "locd/emoi_markov/masked_emoi.hpp"

#include <opencv2/imgproc.hpp>

namespace {

using namespace locd::emoi;

locd::GridGeometry geometry(int side, double resolution) {
  locd::GridGeometry g;
  g.resolution = resolution;
  g.width = g.height = side;
  return g;
}

cv::Mat_<uchar> all_cells(int side) { return cv::Mat_<uchar>(side, side, uchar(1)); }

struct Moments {
  double mass = 0, mean_x = 0, mean_y = 0, var_x = 0, var_y = 0;
};
Moments moments_of(const MarkovGrid& grid) {
  Moments m;
  const auto& b = grid.belief();
  for (int r = 0; r < b.rows; ++r) {
    for (int c = 0; c < b.cols; ++c) {
      const Eigen::Vector2d p = grid.geometry().center_of(r, c);
      m.mass += b(r, c);
      m.mean_x += b(r, c) * p.x();
      m.mean_y += b(r, c) * p.y();
    }
  }
  m.mean_x /= m.mass;
  m.mean_y /= m.mass;
  for (int r = 0; r < b.rows; ++r) {
    for (int c = 0; c < b.cols; ++c) {
      const Eigen::Vector2d p = grid.geometry().center_of(r, c);
      m.var_x += b(r, c) * (p.x() - m.mean_x) * (p.x() - m.mean_x);
      m.var_y += b(r, c) * (p.y() - m.mean_y) * (p.y() - m.mean_y);
    }
  }
  m.var_x /= m.mass;
  m.var_y /= m.mass;
  return m;
}

TEST(MarkovGrid, BoxWidthsComposeTheRequestedVariance) {
  for (double sigma : {4.0, 7.5, 15.0, 40.0}) {
    const auto widths = box_widths_for_gaussian(sigma, 3);
    double variance = 0.0;
    for (int w : widths) {
      EXPECT_EQ(w % 2, 1);
      variance += (w * w - 1) / 12.0;
    }
    EXPECT_NEAR(variance, sigma * sigma, 0.1 * sigma * sigma) << "sigma " << sigma;
  }
}

TEST(MarkovGrid, MotionUpdateConservesMassShiftsMeanAndAddsVariance) {
  for (double blur : {0.15, 1.2}) {  // Gaussian kernel path and box-pass path (0.1 m cells)
    MarkovGrid grid(geometry(300, 0.1), all_cells(300));
    grid.set_gaussian({15.0, 15.0}, 1.0);
    const Moments before = moments_of(grid);
    const auto report = grid.motion_update({1.23, -0.77}, blur);
    const Moments after = moments_of(grid);
    EXPECT_NEAR(report.mass_lost, 0.0, 1e-5) << "blur " << blur;
    EXPECT_FALSE(report.reset);
    EXPECT_NEAR(after.mass, 1.0, 1e-5);
    // A blur wider than 3 cells rounds the shift to whole cells (at most half a cell off).
    const double shift_tolerance = blur > 0.3 ? 0.05 : 0.01;
    EXPECT_NEAR(after.mean_x - before.mean_x, 1.23, shift_tolerance);
    EXPECT_NEAR(after.mean_y - before.mean_y, -0.77, shift_tolerance);
    // Blur adds blur^2; the bilinear shift adds at most frac * (1 - frac) cells^2.
    EXPECT_NEAR(after.var_x - before.var_x, blur * blur, 0.05 * blur * blur + 0.0025);
    EXPECT_NEAR(after.var_y - before.var_y, blur * blur, 0.05 * blur * blur + 0.0025);
  }
}

// The motion update runs on the window the occupied cells can reach: the same as shift + blur
// on the whole grid (zero border), for both blur paths, near a map edge too; cells outside
// occupied() are zero; the windowed sensor update (likelihood on a window, one value outside)
// equals the whole-grid update with that likelihood.
TEST(MarkovGrid, WindowedUpdatesEqualTheWholeGrid) {
  for (double blur : {0.15, 1.2}) {
    for (const Eigen::Vector2d& start : {Eigen::Vector2d(15.0, 12.0), Eigen::Vector2d(2.0, 27.5)}) {
      MarkovGrid grid(geometry(300, 0.1), all_cells(300));
      grid.set_gaussian(start, 0.5);
      EXPECT_LT(grid.occupied().area(), 300 * 300);  // tails below 1e-30 are flushed
      const cv::Mat_<float> before = grid.belief().clone();
      const Eigen::Vector2d shift(1.23, -0.77);
      grid.motion_update(shift, blur);
      cv::Mat_<float> expected;
      const double sigma = blur / 0.1;
      if (sigma > 3.0) {
        const int dx = static_cast<int>(std::lround(12.3)), dy = static_cast<int>(std::lround(-7.7));
        cv::warpAffine(before, expected, cv::Matx23d(1, 0, dx, 0, 1, dy), before.size(), cv::INTER_NEAREST,
                       cv::BORDER_CONSTANT, 0.0);
        for (int width : box_widths_for_gaussian(sigma, 3))
          cv::blur(expected, expected, cv::Size(width, width), cv::Point(-1, -1), cv::BORDER_CONSTANT);
      } else {
        cv::warpAffine(before, expected, cv::Matx23d(1, 0, 12.3, 0, 1, -7.7), before.size(), cv::INTER_LINEAR,
                       cv::BORDER_CONSTANT, 0.0);
        const int half = static_cast<int>(std::ceil(3.0 * sigma));
        cv::GaussianBlur(expected, expected, cv::Size(2 * half + 1, 2 * half + 1), sigma, sigma, cv::BORDER_CONSTANT);
      }
      expected /= cv::sum(expected)[0];
      double peak = 0.0;
      cv::minMaxLoc(expected, nullptr, &peak);
      EXPECT_LT(cv::norm(grid.belief(), expected, cv::NORM_INF), 1e-5 * peak) << "blur " << blur;
      EXPECT_NEAR(cv::sum(grid.belief())[0], 1.0, 1e-5);
      cv::Mat_<uchar> outside(300, 300, uchar(1));
      outside(grid.occupied()).setTo(0);
      EXPECT_EQ(cv::countNonZero((grid.belief() != 0.0f) & outside), 0);
      // Sensor update: a likelihood on a window, 0.01 elsewhere, against the same on the whole grid.
      MarkovGrid whole(geometry(300, 0.1), all_cells(300));
      whole.set_gaussian(start, 0.5);
      whole.motion_update(shift, blur);
      const cv::Rect window(100, 60, 80, 90);
      cv::Mat_<float> values(window.size());
      cv::randu(values, 0.0f, 1.0f);
      cv::Mat_<float> full(300, 300, 0.01f);
      values.copyTo(full(window));
      const auto windowed = grid.sensor_update_likelihood(values, window, 0.01f);
      const auto reference = whole.sensor_update_likelihood(full);
      EXPECT_NEAR(windowed.evidence, reference.evidence, 1e-5 * reference.evidence);
      cv::minMaxLoc(whole.belief(), nullptr, &peak);
      EXPECT_LT(cv::norm(grid.belief(), whole.belief(), cv::NORM_INF), 1e-6 * peak);
      EXPECT_NEAR(cv::sum(grid.belief())[0], 1.0, 1e-5);
    }
  }
}

TEST(MarkovGrid, MassPushedOffTheMapIsReportedAndTheRestRenormalised) {
  MarkovGrid grid(geometry(100, 0.1), all_cells(100));
  grid.set_gaussian({9.0, 5.0}, 0.2);
  const auto report = grid.motion_update({1.0, 0.0}, 0.0);  // the blob centre moves to x = 10 (the edge)
  EXPECT_NEAR(report.mass_lost, 0.5, 0.05);
  EXPECT_NEAR(cv::sum(grid.belief())[0], 1.0, 1e-5);
  const auto gone = grid.motion_update({50.0, 0.0}, 0.0);
  EXPECT_TRUE(gone.reset);
  EXPECT_NEAR(grid.belief()(50, 50), 1.0 / (100 * 100), 1e-9);
}

TEST(MarkovGrid, BeliefStaysOffCellsWithoutData) {
  cv::Mat_<uchar> support = all_cells(50);
  support(cv::Rect(0, 0, 25, 50)).setTo(0);
  MarkovGrid grid(geometry(50, 0.1), support);
  EXPECT_EQ(grid.belief()(10, 10), 0.0f);
  EXPECT_NEAR(grid.belief()(10, 30), 1.0 / (25 * 50), 1e-9);
  grid.motion_update({-1.0, 0.0}, 0.3);
  EXPECT_EQ(grid.belief()(10, 10), 0.0f);
  EXPECT_NEAR(cv::sum(grid.belief())[0], 1.0, 1e-5);
}

TEST(SensorModel, FullDiskLikelihoodIsEquationEightMultipliedOverRadii) {
  EmoiLayers layers;
  layers.radii_m = {5.0, 10.0};
  layers.layers = {cv::Mat_<float>(4, 4, 0.0f), cv::Mat_<float>(4, 4, 0.0f)};
  layers.layers[0](1, 2) = 0.1f;
  layers.layers[1](1, 2) = -0.05f;
  SensorModelConfig sensor;
  sensor.sigma_m = 0.05;
  sensor.min_coverage = 0.2;
  sensor.full_coverage = 0.6;
  EmoiObservation z{{0.02, 0.01}, {1.0, 0.4}};  // radius 10 at half weight
  std::vector<double> weights;
  const auto log_p = full_disk_log_likelihood(layers, z, sensor, &weights);
  ASSERT_EQ(weights.size(), 2u);
  EXPECT_DOUBLE_EQ(weights[0], 1.0);
  EXPECT_NEAR(weights[1], 0.5, 1e-12);
  const double expected = -(std::pow(0.1 - 0.02, 2) + 0.5 * std::pow(-0.05 - 0.01, 2)) / (0.05 * 0.05);
  EXPECT_NEAR(log_p(1, 2), expected, 1e-5);
  // Similarity(eq. 8) = exp(-(d / sigma)^2) for one radius at full weight.
  const auto single = full_disk_log_likelihood(layers, {{0.02, 0.0}, {1.0, 0.0}}, sensor);
  EXPECT_NEAR(std::exp(single(1, 2)), std::exp(-std::pow((0.1 - 0.02) / 0.05, 2)), 1e-6);
  EXPECT_DOUBLE_EQ(coverage_weight(0.1, sensor), 0.0);  // thin local map: left out
}

TEST(SensorModel, SensorUpdateMultipliesFloorsAndNormalises) {
  MarkovGrid grid(geometry(4, 1.0), all_cells(4));
  cv::Mat_<float> log_p(4, 4, -100.0f);  // far below the floor
  log_p(2, 1) = 0.0f;
  log_p(3, 3) = std::log(0.5f);
  log_p(0, 0) = std::numeric_limits<float>::quiet_NaN();  // no data: floor
  const auto report = grid.sensor_update(log_p, 1e-3);
  const double prior = 1.0 / 16.0;
  const double evidence = prior * (1.0 + 0.5 + 14 * 1e-3);
  EXPECT_NEAR(report.evidence, evidence, 1e-6);
  EXPECT_NEAR(grid.belief()(2, 1), prior / evidence, 1e-5);
  EXPECT_NEAR(grid.belief()(3, 3), 0.5 * prior / evidence, 1e-5);
  EXPECT_NEAR(grid.belief()(0, 0), 1e-3 * prior / evidence, 1e-6);
  EXPECT_NEAR(cv::sum(grid.belief())[0], 1.0, 1e-6);
  const auto summary = grid.summary();
  EXPECT_NEAR(summary.mode.x(), 1.5, 1e-12);
  EXPECT_NEAR(summary.mode.y(), 2.5, 1e-12);
}

ElevationMap hills(int side, double resolution, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 3.0f);
  cv::Mat_<float> coarse(6, 6);
  for (auto& v : coarse) v = u(rng);
  ElevationMap map;
  map.geometry = geometry(side, resolution);
  cv::resize(coarse, map.elevation, cv::Size(side, side), 0, 0, cv::INTER_CUBIC);
  for (auto& v : map.elevation) v += 0.2f * u(rng);
  return map;
}

// EMOI over the observed set M, brute force, at one cell (the reference for the DFT match).
double masked_direct(const ElevationMap& map, const cv::Mat_<float>& patch, int radius_cells, int row, int col) {
  const int half = patch.rows / 2;
  const double res = map.geometry.resolution;
  double sum = 0.0;
  int n = 0;
  for (int dr = -radius_cells; dr <= radius_cells; ++dr) {
    for (int dc = -radius_cells; dc <= radius_cells; ++dc) {
      if (dr * dr + dc * dc >= radius_cells * radius_cells || !std::isfinite(patch(half + dr, half + dc))) continue;
      const int p = row + dr, q = col + dc;
      if (p < 0 || q < 0 || p >= map.geometry.height || q >= map.geometry.width) continue;
      sum += (dr * dr + dc * dc) * res * res * (map.elevation(p, q) - map.elevation(row, col));
      ++n;
    }
  }
  const double radius_m = radius_cells * res;
  return sum / n / (radius_m * radius_m);
}

TEST(MaskedEmoi, MatchEqualsDirectSumOverTheObservedCells) {
  const ElevationMap map = hills(120, 0.5, 3);
  const std::vector<double> radii{3.0, 6.0};  // 6 and 12 cells
  MaskedEmoiMatcher matcher(map, radii, 0.5);
  ASSERT_EQ(matcher.factor(), 1);
  const int half = matcher.patch_radius();
  const int row0 = 60, col0 = 50;
  cv::Mat_<float> patch(2 * half + 1, 2 * half + 1, std::numeric_limits<float>::quiet_NaN());
  for (int i = -half; i <= half; ++i) {
    for (int j = -half; j <= half; ++j) {
      if (i < 0 && j > -3) continue;  // an unobserved sector
      patch(i + half, j + half) = map.elevation(row0 + i, col0 + j) - map.elevation(row0, col0);
    }
  }
  const auto match = matcher.match(patch);
  for (size_t k = 0; k < radii.size(); ++k) {
    const int radius_cells = radius_in_cells(radii[k], 0.5);
    EXPECT_LT(match.coverage[k], 0.75);
    // At the true cell the DSM side equals the robot side (same cells, same elevations).
    EXPECT_NEAR(match.dsm_emoi[k](row0, col0), match.robot_emoi[k], 1e-5);
    EXPECT_NEAR(match.robot_emoi[k], masked_direct(map, patch, radius_cells, row0, col0), 1e-9);
    // Elsewhere, and near the border, the DFT layer equals the brute-force sum over M.
    for (const auto& [r, c] : {std::pair{20, 90}, std::pair{3, 5}, std::pair{116, 118}}) {
      EXPECT_NEAR(match.dsm_emoi[k](r, c), masked_direct(map, patch, radius_cells, r, c), 1e-4)
          << "radius " << radii[k] << " at " << r << ", " << c;
    }
  }
  // The likelihood peaks at the true cell.
  SensorModelConfig sensor;
  sensor.min_coverage = 0.05;
  const auto p = matcher.likelihood(match, sensor, 120, 120);
  cv::Point best;
  cv::minMaxLoc(p, nullptr, nullptr, nullptr, &best);
  EXPECT_LE(std::hypot(best.x - col0, best.y - row0), 1.5);
}

TEST(MaskedEmoi, FullPatchReproducesTheFullDiskLayer) {
  const ElevationMap map = hills(80, 0.5, 5);
  MaskedEmoiMatcher matcher(map, {4.0}, 0.5);
  const int half = matcher.patch_radius();
  cv::Mat_<float> patch(2 * half + 1, 2 * half + 1);
  for (int i = -half; i <= half; ++i)
    for (int j = -half; j <= half; ++j) patch(i + half, j + half) = map.elevation(40 + i, 40 + j) - map.elevation(40, 40);
  const auto match = matcher.match(patch);
  const auto full = emoi_direct(map, 4.0);
  EXPECT_NEAR(match.coverage[0], 1.0, 1e-12);
  EXPECT_NEAR(match.robot_emoi[0], full(40, 40), 1e-9);
  EXPECT_NEAR(match.dsm_emoi[0](30, 45), full(30, 45), 1e-4);
}

}  // namespace

namespace {

// A robot whose ground height is 0.3 m off: every radius shifts by 0.3 * mean(r^2)/R^2; with the
// offset marginalised the true cell keeps its likelihood and stays among the best.
TEST(MaskedEmoi, GroundOffsetIsMarginalised) {
  const ElevationMap map = hills(120, 0.5, 3);
  const std::vector<double> radii{3.0, 6.0, 10.0};
  MaskedEmoiMatcher matcher(map, radii, 0.5);
  const int half = matcher.patch_radius();
  const int row0 = 60, col0 = 60;
  cv::Mat_<float> patch(2 * half + 1, 2 * half + 1, std::numeric_limits<float>::quiet_NaN());
  for (int i = -half; i <= half; ++i) {
    for (int j = -half; j <= half; ++j) {
      if (i < -2) continue;
      patch(i + half, j + half) = map.elevation(row0 + i, col0 + j) - (map.elevation(row0, col0) + 0.3f);
    }
  }
  const auto match = matcher.match(patch);
  for (size_t k = 0; k < radii.size(); ++k) {
    EXPECT_NEAR(match.robot_emoi[k] - match.dsm_emoi[k](row0, col0), 0.3 * match.offset_gain[k], 1e-5);
    EXPECT_LT(match.offset_gain[k], -0.3);
  }
  SensorModelConfig plain;
  plain.min_coverage = 0.05;
  plain.full_coverage = 0.5;
  SensorModelConfig marginalised = plain;
  marginalised.ground_offset_stddev_m = 1.0;
  const auto log_plain = matcher.coarse_log_likelihood(match, plain);
  const auto log_marginalised = matcher.coarse_log_likelihood(match, marginalised);
  EXPECT_LT(log_plain(row0, col0), -5.0);
  EXPECT_GT(log_marginalised(row0, col0), -0.5);
  double best = 0.0;
  cv::minMaxLoc(log_marginalised, nullptr, &best);
  EXPECT_GT(log_marginalised(row0, col0), best - 0.5);  // among the best cells (one dof fewer to match)
}

}  // namespace
