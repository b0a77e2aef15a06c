// The odometry distortion marginalised in the masked sensor model: the local map rebuilt under a
// hypothesis, the hypothesis grid, the mixture likelihood against its direct formula, the direct
// masked sums against the DFT match.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Geometry>

#include "locd/emoi_markov/local_elevation_map.hpp"
#include "locd/emoi_markov/markov_grid.hpp"
#include "locd/emoi_markov/masked_emoi.hpp"
#include "locd/emoi_markov/odometry_distortion.hpp"
#include "locd/sdk/errors.hpp"

#include <opencv2/imgproc.hpp>

namespace {

using namespace locd::emoi;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

Eigen::Matrix2d scale_rotation(double scale, double angle) {
  return scale * Eigen::Rotation2Dd(angle).toRotationMatrix();
}

// A robot drives straight; odometry reports A times every true displacement (scale and
// direction error). Isolated points are seen along the way and placed with the pose of the
// moment, once with odometry and once with the true pose. Rebuilt under B = A^-1, the odometry
// map's patch equals the true-pose map's patch cell for cell; as odometry placed it, it does not.
TEST(DistortedLocalMap, PatchRebuiltUnderTheTrueDistortionEqualsTheTruePosePatch) {
  LocalMapConfig config;
  config.resolution = 0.1;
  config.size_m = 60.0;
  LocalElevationMap odometry_map(config), true_map(config);
  const Eigen::Matrix2d A = scale_rotation(1.1, 0.08);
  const Eigen::Vector2d direction(std::cos(0.3), std::sin(0.3));
  const double length = 10.0, cell_m = 0.5;
  const int radius_cells = 30;
  auto true_position = [&](double t) { return Eigen::Vector2d(t * direction); };
  odometry_map.follow(Eigen::Vector2d::Zero());
  true_map.follow(Eigen::Vector2d::Zero());
  // Points at patch-cell centres around the final true pose, each with its own height.
  const std::vector<Eigen::Vector2i> offsets{{-20, 3}, {-10, -8}, {5, 12}, {15, -2}, {0, -18},
                                             {-25, -5}, {22, 9}, {-4, 26}, {8, -24}, {-16, 16}};
  const Eigen::Vector2d final_true = true_position(length);
  for (int step = 0; step <= 20; ++step) {
    const double t = step * 0.5;
    const Eigen::Vector2d truth = true_position(t), odometry = A * truth;
    odometry_map.record_pose(t, odometry);
    true_map.record_pose(t, truth);
    for (size_t j = 0; j < offsets.size(); ++j) {
      if (static_cast<int>(j * 2) != step) continue;  // point j seen once, at travel j metres
      const Eigen::Vector2d point = final_true + offsets[j].cast<double>() * cell_m;
      const Eigen::Vector2d seen_from_robot = point - truth;  // what the laser measures
      const double height = 1.0 + 0.25 * static_cast<double>(j);
      ASSERT_TRUE(odometry_map.insert_point({(odometry + seen_from_robot).x(), (odometry + seen_from_robot).y(), height}, t));
      ASSERT_TRUE(true_map.insert_point({point.x(), point.y(), height}, t));
    }
  }
  const Eigen::Vector2d final_odometry = A * final_true;
  const cv::Mat_<float> expected = true_map.robot_patch(final_true, 0.0, cell_m, radius_cells, 0.5, length);
  const cv::Mat_<float> rebuilt =
      odometry_map.robot_patch(final_odometry, 0.0, cell_m, radius_cells, 0.5, length, A.inverse());
  const cv::Mat_<float> as_placed = odometry_map.robot_patch(final_odometry, 0.0, cell_m, radius_cells, 0.5, length);
  int observed = 0, misplaced = 0;
  for (int i = 0; i < expected.rows; ++i) {
    for (int j = 0; j < expected.cols; ++j) {
      ASSERT_EQ(std::isfinite(expected(i, j)), std::isfinite(rebuilt(i, j))) << "cell " << i << ", " << j;
      if (!std::isfinite(expected(i, j))) continue;
      ++observed;
      EXPECT_FLOAT_EQ(rebuilt(i, j), expected(i, j));
      if (!(as_placed(i, j) == expected(i, j))) ++misplaced;
    }
  }
  EXPECT_EQ(observed, static_cast<int>(offsets.size()));
  EXPECT_GE(misplaced, 5);  // the old points are 0.5 - 1.3 m off as odometry placed them
  // The identity rebuilds the map as odometry placed it.
  const cv::Mat_<float> identity = odometry_map.robot_patch(final_odometry, 0.0, cell_m, radius_cells, 0.5, length,
                                                            Eigen::Matrix2d::Identity());
  for (int i = 0; i < identity.rows; ++i)
    for (int j = 0; j < identity.cols; ++j)
      EXPECT_TRUE(identity(i, j) == as_placed(i, j) || (std::isnan(identity(i, j)) && std::isnan(as_placed(i, j))));
}

// The binner shared by the hypotheses of one update leaves out the cells no hypothesis up to
// max_correction can move into the patch: the same patches as binning every cell, every time.
TEST(DistortedLocalMap, BinnerEqualsBinningEveryCell) {
  LocalElevationMap::PatchCells cells;
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> position(-30.0f, 30.0f), height(-2.0f, 2.0f);
  for (int k = 0; k < 20000; ++k) {
    cells.relative.emplace_back(position(rng), position(rng));
    // Runs of cells written at the same travel mark share their displacement.
    const float back = static_cast<float>(k / 500) * 0.8f;
    cells.since_written.emplace_back(-back, 0.3f * back);
    cells.elevation.push_back(height(rng));
  }
  const auto hypotheses = distortion_hypotheses(0.1, 0.1, 5);
  double max_correction = 0.0;
  for (const auto& h : hypotheses) max_correction = std::max(max_correction, (h.transform - Eigen::Matrix2d::Identity()).norm());
  const PatchBinner binner(cells, 0.4, 0.5, 20, 1.0, max_correction);
  int observed = 0;
  for (const auto& h : hypotheses) {
    const cv::Mat_<float> expected = LocalElevationMap::bin_patch(cells, 0.4, 0.5, 20, 1.0, h.transform);
    const cv::Mat_<float> got = binner.patch(h.transform);
    for (int i = 0; i < got.rows; ++i)
      for (int j = 0; j < got.cols; ++j) {
        ASSERT_EQ(std::isnan(got(i, j)), std::isnan(expected(i, j))) << i << ", " << j;
        if (std::isnan(got(i, j))) continue;
        ASSERT_FLOAT_EQ(got(i, j), expected(i, j));
        ++observed;
      }
  }
  EXPECT_GT(observed, 25 * 1000);
  EXPECT_THROW(binner.patch(1.5 * Eigen::Matrix2d::Identity()), locd::InputError);
}

TEST(DistortedLocalMap, RecordedPositionsInterpolateAndClamp) {
  LocalMapConfig config;
  config.memory_distance_m = 5.0;
  LocalElevationMap map(config);
  for (int k = 0; k <= 20; ++k) map.record_pose(k, Eigen::Vector2d(2.0 * k, -k));
  EXPECT_NEAR((map.recorded_position(18.25) - Eigen::Vector2d(36.5, -18.25)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((map.recorded_position(100.0) - Eigen::Vector2d(40.0, -20.0)).norm(), 0.0, 1e-12);
  // Records before the memory (travel 20 - 5 = 15) are dropped: earlier marks clamp to the one at 15.
  EXPECT_NEAR((map.recorded_position(0.0) - Eigen::Vector2d(30.0, -15.0)).norm(), 0.0, 1e-12);
}

TEST(DistortionHypotheses, GridWeightsSumToOneAndFollowTheGaussian) {
  const auto hypotheses = distortion_hypotheses(0.1, 0.05, 5);
  ASSERT_EQ(hypotheses.size(), 25u);
  double total = 0.0;
  for (const auto& h : hypotheses) {
    total += h.weight;
    EXPECT_LT((h.transform - scale_rotation(h.scale, h.direction_rad)).norm(), 1e-12);
    const double us = (h.scale - 1.0) / 0.1, ud = h.direction_rad / 0.05;
    EXPECT_NEAR(h.weight / hypotheses[12].weight, std::exp(-0.5 * (us * us + ud * ud)), 1e-12);
  }
  EXPECT_NEAR(total, 1.0, 1e-12);
  EXPECT_LT((hypotheses[12].transform - Eigen::Matrix2d::Identity()).norm(), 1e-12);  // the centre
  EXPECT_NEAR(hypotheses.front().scale, 0.8, 1e-12);
  EXPECT_NEAR(hypotheses.back().direction_rad, 0.1, 1e-12);
  const auto single = distortion_hypotheses(0.1, 0.1, 1);
  ASSERT_EQ(single.size(), 1u);
  EXPECT_DOUBLE_EQ(single[0].weight, 1.0);
  EXPECT_DOUBLE_EQ(distortion_grid_variance(1), 0.0);
  const double w1 = std::exp(-0.5), w2 = std::exp(-2.0);
  EXPECT_NEAR(distortion_grid_variance(5), (2 * w1 + 8 * w2) / (1 + 2 * w1 + 2 * w2), 1e-12);
  EXPECT_THROW(distortion_hypotheses(0.1, 0.1, 4), locd::ConfigError);
}

// L_mix = sum_b w_b prior_b(x) l_b(x) / sum_b w_b prior_b(x), prior_b the previous belief moved
// by B_b shift (bilinear, no blur here): computed by splatting every source cell by hand.
TEST(DistortionMixture, EqualsTheDirectFormula) {
  cv::Mat_<float> previous(40, 40, 0.0f);
  previous(10, 12) = 0.5f;
  previous(11, 12) = 0.2f;
  previous(20, 25) = 0.3f;
  const Eigen::Vector2d shift(4.0, -2.0);
  std::vector<DistortionHypothesis> hypotheses;
  for (auto [scale, weight] : {std::pair{1.0, 0.4}, {1.25, 0.2}, {0.75, 0.3}, {0.5, 0.1}}) {
    DistortionHypothesis h;
    h.scale = scale;
    h.transform = scale * Eigen::Matrix2d::Identity();
    h.weight = weight;
    hypotheses.push_back(h);
  }
  std::vector<cv::Point> cells;
  for (int r = 4; r < 24; ++r)
    for (int c = 10; c < 32; ++c) cells.emplace_back(c, r);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> unit(0.01f, 1.0f);
  std::vector<std::vector<float>> likelihoods(hypotheses.size(), std::vector<float>(cells.size()));
  for (auto& l : likelihoods)
    for (auto& v : l) v = unit(rng);
  std::vector<double> posterior;
  const auto mixed = mixture_likelihood(previous, shift, hypotheses, 0.0, cells, likelihoods, &posterior);
  auto tent = [](double d) { return std::max(0.0, 1.0 - std::abs(d)); };
  int with_prior = 0;
  for (size_t i = 0; i < cells.size(); ++i) {
    double numerator = 0.0, denominator = 0.0, mean = 0.0;
    for (size_t b = 0; b < hypotheses.size(); ++b) {
      const Eigen::Vector2d t = hypotheses[b].transform * shift;
      double prior = 0.0;
      for (int r = 0; r < previous.rows; ++r)
        for (int c = 0; c < previous.cols; ++c)
          if (previous(r, c) > 0) prior += previous(r, c) * tent(cells[i].x - c - t.x()) * tent(cells[i].y - r - t.y());
      numerator += hypotheses[b].weight * prior * likelihoods[b][i];
      denominator += hypotheses[b].weight * prior;
      mean += hypotheses[b].weight * likelihoods[b][i];
    }
    const double expected = denominator > 1e-30 ? numerator / denominator : mean;
    with_prior += denominator > 1e-30 ? 1 : 0;
    EXPECT_NEAR(mixed[i], expected, 1e-5 * expected) << "cell " << cells[i];
  }
  EXPECT_GE(with_prior, 8);
  double total = 0.0;
  for (double p : posterior) total += p;
  EXPECT_NEAR(total, 1.0, 1e-9);
  // A likelihood that does not depend on the hypothesis comes out unchanged.
  std::vector<std::vector<float>> same(hypotheses.size(), likelihoods[0]);
  const auto unchanged = mixture_likelihood(previous, shift, hypotheses, 1.5, cells, same);
  for (size_t i = 0; i < cells.size(); ++i) EXPECT_NEAR(unchanged[i], likelihoods[0][i], 1e-6);
}

TEST(DistortionMixture, CellsHoldingMassAreTheLargestAndBounded) {
  cv::Mat_<float> belief(10, 10, 0.0f);
  belief(2, 3) = 0.5f;
  belief(7, 1) = 0.3f;
  belief(5, 5) = 0.15f;
  belief(0, 9) = 0.05f;
  const auto cells = cells_holding_mass(belief, 0.9, 10);
  ASSERT_EQ(cells.size(), 3u);
  EXPECT_EQ(cells[0], cv::Point(3, 2));
  EXPECT_EQ(cells[1], cv::Point(1, 7));
  EXPECT_EQ(cells[2], cv::Point(5, 5));
  EXPECT_EQ(cells_holding_mass(belief, 1.0, 10).size(), 4u);
  EXPECT_TRUE(cells_holding_mass(belief, 0.9, 2).empty());                      // needs 3
  EXPECT_TRUE(cells_holding_mass(cv::Mat_<float>(10, 10, 0.01f), 0.5, 20).empty());  // needs 50
}

ElevationMap rough_map(int side, double resolution, unsigned seed, double nodata) {
  ElevationMap map;
  map.geometry.resolution = resolution;
  map.geometry.width = map.geometry.height = side;
  map.elevation = cv::Mat_<float>(side, side);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> phase(0.0, 6.28), unit(0.0, 1.0);
  const double a = phase(rng), b = phase(rng);
  for (int r = 0; r < side; ++r)
    for (int c = 0; c < side; ++c)
      map.elevation(r, c) = static_cast<float>(3.0 * std::sin(0.11 * c + a) * std::cos(0.07 * r + b) + 0.5 * unit(rng) +
                                               (unit(rng) < nodata ? std::nan("") : 0.0));
  return map;
}

TEST(DistortionMixture, DirectMaskedSumsEqualTheDftMatch) {
  for (const float offset : {0.0f, 312.0f}) {  // the direct sums run in float: a high DSM must not matter
    ElevationMap map = rough_map(100, 0.5, 7, 0.1);
    map.elevation += offset;
    MaskedEmoiMatcher matcher(map, {2.0, 6.0, 4.0}, 0.5);
    const int half = matcher.patch_radius();
    cv::Mat_<float> patch(2 * half + 1, 2 * half + 1, kNaN);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int i = 0; i < patch.rows; ++i)
      for (int j = 0; j < patch.cols; ++j)
        if (i > half / 2 || unit(rng) < 0.3) patch(i, j) = static_cast<float>(2.0 * unit(rng) - 1.0);
    const std::vector<cv::Point> cells{{50, 50}, {0, 0}, {99, 3}, {5, 97}, {60, 12}, {88, 88}, {-1, 4}};
    const auto full = matcher.match(patch);
    const auto at = matcher.match_at(patch, cells);
    int compared = 0;
    for (size_t k = 0; k < 3; ++k) {
      EXPECT_DOUBLE_EQ(at.robot_emoi[k], full.robot_emoi[k]);
      EXPECT_DOUBLE_EQ(at.coverage[k], full.coverage[k]);
      ASSERT_EQ(at.dsm_emoi[k].cols, static_cast<int>(cells.size()));
      for (size_t i = 0; i < cells.size(); ++i) {
        const cv::Point& x = cells[i];
        if (x.x < 0 || x.y < 0 || x.x >= 100 || x.y >= 100) {
          EXPECT_TRUE(std::isnan(at.dsm_emoi[k](0, static_cast<int>(i))));
          continue;
        }
        const float dft = full.dsm_emoi[k](x.y, x.x);
        const float direct = at.dsm_emoi[k](0, static_cast<int>(i));
        ASSERT_EQ(std::isfinite(dft), std::isfinite(direct)) << "radius " << k << " cell " << x;
        if (!std::isfinite(dft)) continue;
        EXPECT_NEAR(direct, dft, 1e-4 * std::max(1.0f, std::abs(dft))) << "radius " << k << " cell " << x;
        ++compared;
      }
    }
    EXPECT_GE(compared, 12);
  }
}

// The shape residual's direct formula at cell x of a 100 x 100 map: min over c of the mean of
// (T - e - c)^2 over the observed cells of the disk of `reach` cells that have data and are not
// `left_out`; NaN without any.
template <class LeftOut>
double direct_shape_residual(const ElevationMap& map, const cv::Mat_<float>& patch, const cv::Point& x, int reach,
                             LeftOut left_out) {
  const int half = patch.rows / 2;
  double sum = 0.0, square = 0.0, n = 0.0;
  for (int dr = -reach; dr <= reach; ++dr)
    for (int dc = -reach; dc <= reach; ++dc) {
      const int r = x.y + dr, c = x.x + dc;
      if (dr * dr + dc * dc >= reach * reach || r < 0 || c < 0 || r >= 100 || c >= 100) continue;
      const float t = patch(half + dr, half + dc), e = map.elevation(r, c);
      if (!std::isfinite(t) || !std::isfinite(e) || left_out(r, c)) continue;
      const double d = static_cast<double>(t) - e;
      sum += d;
      square += d * d;
      n += 1.0;
    }
  return n < 1.0 ? std::nan("") : square / n - (sum / n) * (sum / n);
}

// The shape term: at each listed cell, min over c of the mean of (T - e - c)^2 over the observed
// cells of the largest disk that have data, against that formula summed directly; the map's own
// elevations cut out as the patch (lifted by a constant) match exactly where they were cut and
// nowhere better; and the log-likelihood drops by residual / (2 shape_sigma^2).
TEST(ShapeResidual, EqualsTheBestOffsetMeanSquaredDifference) {
  for (const float lift : {0.0f, 312.0f}) {
    ElevationMap map = rough_map(100, 0.5, 5, 0.1);
    map.elevation += lift;
    MaskedEmoiMatcher matcher(map, {2.0, 6.0, 4.0}, 0.5);
    const int half = matcher.patch_radius();
    const int reach = locd::emoi::radius_in_cells(6.0, 0.5);
    const cv::Point cut(47, 52);
    cv::Mat_<float> patch(2 * half + 1, 2 * half + 1, kNaN);
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int i = -half; i <= half; ++i)
      for (int j = -half; j <= half; ++j)
        if (i > -half / 2 || unit(rng) < 0.3) patch(i + half, j + half) = map.elevation(cut.y + i, cut.x + j) - lift + 1.5f;
    std::vector<cv::Point> cells{cut, {0, 0}, {99, 3}, {5, 97}, {60, 12}, {88, 88}, {-1, 4}};
    for (int k = 0; k < 40; ++k) cells.emplace_back(15 + k * 7 % 70, 15 + k * 13 % 70);
    const auto at = matcher.match_at(patch, cells, true);
    ASSERT_EQ(at.shape_residual.cols, static_cast<int>(cells.size()));
    EXPECT_TRUE(matcher.match_at(patch, cells).shape_residual.empty());
    int compared = 0;
    for (size_t i = 0; i < cells.size(); ++i) {
      const cv::Point& x = cells[i];
      const float got = at.shape_residual(0, static_cast<int>(i));
      if (x.x < 0 || x.y < 0 || x.x >= 100 || x.y >= 100 || !std::isfinite(map.elevation(x.y, x.x))) {
        EXPECT_TRUE(std::isnan(got)) << x;
        continue;
      }
      const double expected = direct_shape_residual(map, patch, x, reach, [](int, int) { return false; });
      EXPECT_NEAR(got, expected, 1e-3 * std::max(1.0, expected)) << x << " lift " << lift;
      if (i > 0) {
        EXPECT_GT(got, 0.05) << "only the cut cell matches: " << x;
      }
      ++compared;
    }
    EXPECT_GE(compared, 30);
    EXPECT_NEAR(at.shape_residual(0, 0), 0.0, 1e-3);

    compared = 0;
    SensorModelConfig sensor;
    sensor.min_coverage = 0.0;
    sensor.min_likelihood = 1e-30;
    sensor.sigma_m = 5.0;  // a mild EMOI term: no cell reaches the floor
    sensor.shape_sigma_m = 0.0;
    const cv::Mat_<float> emoi_only = matcher.coarse_log_likelihood(at, sensor);
    sensor.shape_sigma_m = 1.0;
    const cv::Mat_<float> with_shape = matcher.coarse_log_likelihood(at, sensor);
    for (int i = 0; i < with_shape.cols; ++i) {
      if (!std::isfinite(at.shape_residual(0, i)) || with_shape(0, i) <= std::log(1e-30f) + 1e-3f) continue;
      ++compared;
      EXPECT_NEAR(with_shape(0, i), emoi_only(0, i) - at.shape_residual(0, i) / 2, 1e-3) << i;
    }
    EXPECT_GE(compared, 30);
  }
}

// The shape term with shape_edge_step_m: a box on rough ground, cut out as the patch the way a
// ground robot's laser sees it (the box's rim at 1 m, its face's highest return, not its 5 m
// top; its inside unseen). Without the edge mask the rim dominates the residual at the cut; with
// it the residual there is the rough ground's alone, and at every listed cell it equals the
// direct formula over the cells whose DSM 3 x 3 neighbourhood steps by at most the threshold.
TEST(ShapeResidual, LeavesOutTheDsmsEdgeCells) {
  ElevationMap map = rough_map(100, 0.5, 11, 0.05);
  for (auto& v : map.elevation) v *= 0.1f;  // steps within the ground stay below 0.5 m
  const cv::Rect box(40, 45, 12, 9);
  map.elevation(box) += 5.0f;
  const cv::Point cut(44, 44);
  const float step = 0.5f;
  MaskedEmoiMatcher plain(map, {2.0, 6.0, 4.0}, 0.5);
  MaskedEmoiMatcher masked(map, {2.0, 6.0, 4.0}, 0.5, step);
  const int half = plain.patch_radius();
  const int reach = locd::emoi::radius_in_cells(6.0, 0.5);
  cv::Mat_<float> patch(2 * half + 1, 2 * half + 1, kNaN);
  const cv::Rect inner(box.x + 1, box.y + 1, box.width - 2, box.height - 2);
  for (int i = -half; i <= half; ++i)
    for (int j = -half; j <= half; ++j) {
      const cv::Point p(cut.x + j, cut.y + i);
      if (inner.contains(p)) continue;  // the roof: unseen
      const float ground = map.elevation(p.y, p.x);
      patch(i + half, j + half) = box.contains(p) ? ground - 4.0f : ground;  // the rim: 1 m above the ground
    }
  std::vector<cv::Point> cells{cut};
  for (int k = 0; k < 40; ++k) cells.emplace_back(15 + k * 7 % 70, 15 + k * 13 % 70);
  const auto without = plain.match_at(patch, cells, true);
  const auto with = masked.match_at(patch, cells, true);
  EXPECT_GT(without.shape_residual(0, 0), 0.5);
  EXPECT_LT(with.shape_residual(0, 0), 0.01);
  auto edge = [&](int r, int c) {
    float low = map.elevation(r, c), high = low;
    for (int a = -1; a <= 1; ++a)
      for (int b = -1; b <= 1; ++b) {
        const int rr = r + a, cc = c + b;
        if (rr < 0 || cc < 0 || rr >= 100 || cc >= 100 || !std::isfinite(map.elevation(rr, cc))) continue;
        low = std::min(low, map.elevation(rr, cc));
        high = std::max(high, map.elevation(rr, cc));
      }
    return high - low > step;
  };
  int compared = 0;
  for (size_t i = 0; i < cells.size(); ++i) {
    const cv::Point& x = cells[i];
    if (!std::isfinite(map.elevation(x.y, x.x))) continue;
    const double expected = direct_shape_residual(map, patch, x, reach, edge);
    if (std::isnan(expected)) continue;
    EXPECT_NEAR(with.shape_residual(0, static_cast<int>(i)), expected, 1e-3 * std::max(1.0, expected)) << x;
    ++compared;
  }
  EXPECT_GE(compared, 30);
  // The EMOI sums do not change.
  for (size_t k = 0; k < 3; ++k)
    for (int i = 0; i < with.dsm_emoi[k].cols; ++i) {
      const float a = with.dsm_emoi[k](0, i), b = without.dsm_emoi[k](0, i);
      if (std::isfinite(a) || std::isfinite(b)) {
        EXPECT_FLOAT_EQ(a, b);
      }
    }
}

// When the rebuilt local map does not depend on the hypothesis, marginalising changes nothing:
// L_mix equals the plain likelihood on the prior's support, and nothing else is touched.
TEST(DistortionMixture, HypothesisFreeLocalMapKeepsThePlainLikelihood) {
  const ElevationMap map = rough_map(120, 0.5, 11, 0.0);
  MaskedEmoiMatcher matcher(map, {3.0, 6.0}, 0.5);
  const int half = matcher.patch_radius();
  cv::Mat_<float> patch(2 * half + 1, 2 * half + 1, kNaN);
  for (int i = -half; i <= half; ++i)
    for (int j = -half; j <= half; ++j)
      if (i > -3) patch(i + half, j + half) = map.elevation(60 + i, 55 + j) - map.elevation(60, 55);
  SensorModelConfig sensor;
  sensor.min_coverage = 0.05;
  sensor.shape_sigma_m = 0.0;  // the whole-map match (plain) has no shape term
  const auto match = matcher.match(patch);
  cv::Mat_<float> plain = matcher.coarse_log_likelihood(match, sensor);
  cv::exp(plain, plain);
  cv::Mat_<float> previous(120, 120, 0.0f), prior(120, 120, 0.0f);
  previous(58, 50) = 1.0f;
  for (int r = 55; r < 66; ++r)
    for (int c = 50; c < 61; ++c) prior(r, c) = 1.0f / 121.0f;
  DistortionConfig config;
  const auto hypotheses = distortion_hypotheses(0.1, 0.1, 5);
  cv::Mat_<float> likelihood = plain.clone();
  const auto report = apply_distortion_hypotheses(
      matcher, [&](const Eigen::Matrix2d&) { return patch; }, hypotheses, config, sensor, previous, prior,
      Eigen::Vector2d(2.5, 1.0), 1.0, likelihood);
  EXPECT_EQ(report.cells, 121u);
  double total = 0.0;
  for (double p : report.posterior) total += p;
  EXPECT_NEAR(total, 1.0, 1e-9);
  for (int r = 0; r < 120; ++r)
    for (int c = 0; c < 120; ++c)
      ASSERT_NEAR(likelihood(r, c), std::max(plain(r, c), static_cast<float>(sensor.min_likelihood)),
                  2e-5 * plain(r, c) + 1e-7) << r << ", " << c;
  // A prior spread wider than max_cells: nothing runs, nothing changes.
  config.max_cells = 50;
  cv::Mat_<float> untouched = plain.clone();
  EXPECT_EQ(apply_distortion_hypotheses(matcher, [&](const Eigen::Matrix2d&) { return patch; }, hypotheses, config,
                                        sensor, previous, prior, Eigen::Vector2d(2.5, 1.0), 1.0, untouched)
                .cells,
            0u);
  EXPECT_EQ(cv::norm(untouched, plain, cv::NORM_INF), 0.0);
}

// The sparse sensor model (no whole-map match) against the dense one it replaces: the same L_mix
// on the support cells, the smallest of them everywhere else; on the belief grid the same
// interpolated likelihood where only support cells are interpolated; the posteriors proportional
// there; both normalised; and the mass off the support bounded by what the prior held there.
TEST(SparseSensorModel, EqualsTheDenseModelOnTheSupportAndConservesMass) {
  const ElevationMap map = rough_map(240, 0.25, 13, 0.05);  // belief grid 240^2, matching grid 120^2
  MaskedEmoiMatcher matcher(map, {3.0, 6.0}, 0.5);
  ASSERT_EQ(matcher.factor(), 2);
  const int half = matcher.patch_radius();
  const auto& coarse_map = matcher.surface().elevation;
  // The local map rebuilt under B differs from hypothesis to hypothesis.
  auto patch_under = [&](const Eigen::Matrix2d& b) {
    cv::Mat_<float> patch(2 * half + 1, 2 * half + 1, kNaN);
    const int drift = static_cast<int>(std::lround(4.0 * (b(0, 0) - 1.0)));
    for (int i = -half; i <= half; ++i)
      for (int j = -half; j <= half; ++j)
        if (i > -4) patch(i + half, j + half) = coarse_map(60 + i, 55 + j + drift) - coarse_map(60, 55);
    return patch;
  };
  SensorModelConfig sensor;
  sensor.min_coverage = 0.05;
  sensor.min_likelihood = 1e-6;
  const auto hypotheses = distortion_hypotheses(0.1, 0.1, 5);
  DistortionConfig config;
  config.support_mass = 0.999;
  // Two grids with the same concentrated belief; previous = the belief one step back on the matching grid.
  MarkovGrid dense_grid(map.geometry, cv::Mat_<uchar>(240, 240, uchar(1)));
  dense_grid.set_gaussian(Eigen::Vector2d(27.5, 30.0), 1.0);
  MarkovGrid sparse_grid(map.geometry, cv::Mat_<uchar>(240, 240, uchar(1)));
  sparse_grid.set_gaussian(Eigen::Vector2d(27.5, 30.0), 1.0);
  const cv::Mat_<float> prior = matcher.pool(dense_grid.belief(), dense_grid.occupied());
  EXPECT_EQ(cv::norm(prior, matcher.pool(dense_grid.belief()), cv::NORM_INF), 0.0);
  cv::Mat_<float> previous;
  cv::warpAffine(prior, previous, cv::Matx23d(1, 0, -2.0, 0, 1, -1.0), prior.size());
  const Eigen::Vector2d shift_m(1.0, 0.5);

  cv::Mat_<float> dense = matcher.coarse_log_likelihood(matcher.match(patch_under(Eigen::Matrix2d::Identity())), sensor);
  cv::exp(dense, dense);
  const DistortionReport dense_report =
      apply_distortion_hypotheses(matcher, patch_under, hypotheses, config, sensor, previous, prior, shift_m, 0.5, dense);
  const SupportLikelihood sparse =
      support_likelihood(matcher, patch_under, hypotheses, config, sensor, previous, prior, shift_m, 0.5);
  ASSERT_GT(sparse.cells.size(), 20u);
  EXPECT_EQ(sparse.report.cells, dense_report.cells);
  ASSERT_EQ(sparse.report.posterior.size(), dense_report.posterior.size());
  for (size_t b = 0; b < hypotheses.size(); ++b) EXPECT_EQ(sparse.report.posterior[b], dense_report.posterior[b]);
  // The support holds the asked mass; L_mix there is the dense model's, cell for cell.
  double held = 0.0, smallest = 1e9;
  cv::Mat_<uchar> on_support(prior.size(), uchar(0));
  for (size_t i = 0; i < sparse.cells.size(); ++i) {
    const cv::Point& x = sparse.cells[i];
    held += prior(x);
    on_support(x) = 1;
    EXPECT_EQ(sparse.likelihood[i], dense(x)) << x;
    EXPECT_GE(sparse.likelihood[i], static_cast<float>(sensor.min_likelihood));
    smallest = std::min(smallest, static_cast<double>(sparse.likelihood[i]));
  }
  EXPECT_GE(held, 0.999 * cv::sum(prior)[0]);
  EXPECT_EQ(sparse.outside, static_cast<float>(smallest));
  // The identity hypothesis' match: the robot side of the dense match, weights from it.
  const auto full = matcher.match(patch_under(Eigen::Matrix2d::Identity()));
  std::vector<double> weights;
  matcher.coarse_log_likelihood(full, sensor, &weights);
  ASSERT_EQ(sparse.identity.robot_emoi.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_DOUBLE_EQ(sparse.identity.robot_emoi[k], full.robot_emoi[k]);
    EXPECT_DOUBLE_EQ(sparse.weights[k], weights[k]);
  }

  // On the belief grid: the window equals the whole-grid interpolation of (support: L_mix, elsewhere: outside).
  cv::Mat_<float> filled(prior.size(), sparse.outside);
  for (size_t i = 0; i < sparse.cells.size(); ++i) filled(sparse.cells[i]) = sparse.likelihood[i];
  const cv::Mat_<float> filled_fine = matcher.to_fine(filled, 240, 240);
  cv::Rect window;
  const cv::Mat_<float> values = support_likelihood_on_grid(matcher, sparse, 240, 240, window);
  ASSERT_EQ(values.size(), window.size());
  for (int r = 0; r < 240; ++r)
    for (int c = 0; c < 240; ++c) {
      const float expected = filled_fine(r, c);
      const float got = window.contains({c, r}) ? values(r - window.y, c - window.x) : sparse.outside;
      ASSERT_NEAR(got, expected, 1e-6f * expected) << r << ", " << c;
    }
  // The posteriors: both normalised; proportional where the belief-grid cell interpolates
  // support cells only (the dense one has the plain likelihood elsewhere, the sparse `outside`).
  dense_grid.sensor_update_likelihood(matcher.to_fine(dense, 240, 240));
  const auto report = sparse_grid.sensor_update_likelihood(values, window, sparse.outside);
  EXPECT_TRUE(report.applied);
  EXPECT_NEAR(cv::sum(dense_grid.belief())[0], 1.0, 1e-5);
  EXPECT_NEAR(cv::sum(sparse_grid.belief())[0], 1.0, 1e-5);
  double ratio_sum = 0.0, compared_mass = 0.0, far_prior = 0.0, far_posterior = 0.0;
  std::vector<double> ratios;
  MarkovGrid prior_grid(map.geometry, cv::Mat_<uchar>(240, 240, uchar(1)));
  prior_grid.set_gaussian(Eigen::Vector2d(27.5, 30.0), 1.0);
  for (int r = 0; r < 240; ++r)
    for (int c = 0; c < 240; ++c) {
      const int cr = r / 2, cc = c / 2;
      int support_near = 0;  // of the 3 x 3 matching cells around this one
      for (int i = -1; i <= 1; ++i)
        for (int j = -1; j <= 1; ++j) support_near += on_support(std::clamp(cr + i, 0, 119), std::clamp(cc + j, 0, 119));
      const double d = dense_grid.belief()(r, c), p = sparse_grid.belief()(r, c);
      if (support_near == 0) {  // far from the support: exactly `outside` here
        far_prior += prior_grid.belief()(r, c);
        far_posterior += p;
      }
      if (support_near < 9 || d < 1e-7) continue;
      ratios.push_back(p / d);
      ratio_sum += p / d;
      compared_mass += p;
    }
  ASSERT_GT(ratios.size(), 50u);
  EXPECT_GT(compared_mass, 0.5);
  const double mean_ratio = ratio_sum / static_cast<double>(ratios.size());
  for (double q : ratios) ASSERT_NEAR(q, mean_ratio, 1e-4 * mean_ratio);
  // The normalisers differ only by what the cells off the support contribute: < 1 - support_mass.
  EXPECT_NEAR(mean_ratio, 1.0, 2e-3);
  // Far from the support every cell gets the smallest likelihood of all: its share cannot grow,
  // and it held less than 1 - support_mass of the prior.
  EXPECT_LE(far_prior, 1.0 - held / cv::sum(prior)[0] + 1e-6);
  EXPECT_LE(far_posterior, far_prior + 1e-7);
}

}  // namespace
