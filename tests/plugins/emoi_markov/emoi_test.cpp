// EMOI (eq. 7): the DFT layers against the direct formula, on random maps with nodata.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "locd/emoi_markov/emoi.hpp"
#include "locd/emoi_markov/emoi_cache.hpp"
#include "locd/sdk/errors.hpp"

namespace {

using namespace locd::emoi;

ElevationMap random_map(int width, int height, double resolution, double nodata_fraction, double offset,
                        uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> elevation(0.0f, 5.0f);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  ElevationMap map;
  map.geometry.resolution = resolution;
  map.geometry.width = width;
  map.geometry.height = height;
  map.elevation = cv::Mat_<float>(height, width);
  for (auto& v : map.elevation) {
    v = unit(rng) < nodata_fraction ? std::numeric_limits<float>::quiet_NaN()
                                    : static_cast<float>(offset) + elevation(rng);
  }
  return map;
}

// max |a - b| / max |b| over cells with data; both NaN exactly where the centre has no data.
double relative_error(const cv::Mat_<double>& a, const cv::Mat_<double>& b) {
  double worst = 0.0, scale = 0.0;
  for (int r = 0; r < a.rows; ++r) {
    for (int c = 0; c < a.cols; ++c) {
      EXPECT_EQ(std::isnan(a(r, c)), std::isnan(b(r, c))) << "at " << r << ", " << c;
      if (std::isnan(b(r, c))) continue;
      worst = std::max(worst, std::abs(a(r, c) - b(r, c)));
      scale = std::max(scale, std::abs(b(r, c)));
    }
  }
  return worst / scale;
}

TEST(Emoi, FftEqualsDirectFormulaOnRandomMapsWithNodata) {
  const std::vector<double> radii{0.5, 1.0, 1.5};  // R' = 5, 10, 15 cells at 0.1 m
  for (uint64_t seed : {1u, 2u, 3u}) {
    const ElevationMap map = random_map(97, 71, 0.1, 0.15, seed == 3 ? 312.0 : 0.0, seed);
    const auto fft = emoi_fft(map, radii);
    ASSERT_EQ(fft.size(), radii.size());
    for (size_t i = 0; i < radii.size(); ++i) {
      const auto direct = emoi_direct(map, radii[i]);
      EXPECT_LE(relative_error(fft[i], direct), 1e-9) << "seed " << seed << " radius " << radii[i];
    }
  }
}

TEST(Emoi, DirectFormulaByHandOnATinyMap) {
  // 5 x 5 map, radius 2 cells (|k| < 2: the centre and its 8 neighbours at r^2 = 1, 2).
  ElevationMap map;
  map.geometry.resolution = 1.0;
  map.geometry.width = map.geometry.height = 5;
  map.elevation = cv::Mat_<float>(5, 5, 0.0f);
  map.elevation(2, 3) = 2.0f;                                  // east neighbour, r^2 = 1
  map.elevation(1, 1) = 4.0f;                                  // south-west diagonal, r^2 = 2
  map.elevation(3, 2) = std::numeric_limits<float>::quiet_NaN();  // north neighbour: no data
  const auto emoi = emoi_direct(map, 2.0);
  // n = 8 cells with data; sum = 1 * 2 + 2 * 4 = 10; normalised by R^2 = 4.
  EXPECT_NEAR(emoi(2, 2), 10.0 / 8.0 / 4.0, 1e-12);
  EXPECT_TRUE(std::isnan(emoi(3, 2)));
}

TEST(Emoi, PointEmoiOverObservedCellsMatchesLayerAndCountsCoverage) {
  const ElevationMap map = random_map(80, 80, 0.1, 0.0, 0.0, 9);
  const auto direct = emoi_direct(map, 1.0);
  const PointEmoi full = emoi_at(map.elevation, 0.1, 40, 40, map.elevation(40, 40), 1.0);
  EXPECT_NEAR(full.emoi, direct(40, 40), 1e-9);
  EXPECT_DOUBLE_EQ(full.coverage, 1.0);
  cv::Mat_<float> half = map.elevation.clone();
  half(cv::Rect(0, 0, 40, 80)).setTo(std::numeric_limits<float>::quiet_NaN());  // west half unseen
  const PointEmoi partial = emoi_at(half, 0.1, 40, 40, map.elevation(40, 40), 1.0);
  EXPECT_NEAR(partial.coverage, 0.5, 0.05);
  EXPECT_EQ(partial.observed, static_cast<size_t>(std::lround(partial.coverage * 305)));  // 305 cells in |k| < 10
}

TEST(Emoi, RadiusLargerThanTheMapIsAClearError) {
  const ElevationMap map = random_map(40, 30, 0.1, 0.0, 0.0, 4);
  try {
    emoi_fft(map, {5.0});
    FAIL() << "no error";
  } catch (const locd::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("does not fit in the map"), std::string::npos) << e.what();
  }
  EXPECT_THROW(emoi_direct(map, -1.0), locd::ConfigError);
}

TEST(EmoiCache, RoundTripAndKeyFollowsContentAndRadii) {
  const ElevationMap map = random_map(60, 50, 0.1, 0.1, 0.0, 5);
  const std::vector<double> radii{0.5, 1.0};
  const auto directory = std::filesystem::temp_directory_path() / ("emoi_cache_test_" + std::to_string(::getpid()));
  std::filesystem::remove_all(directory);
  const auto first = load_or_compute_layers(map, radii, directory);
  EXPECT_FALSE(first.from_cache);
  const auto second = load_or_compute_layers(map, radii, directory);
  EXPECT_TRUE(second.from_cache);
  ASSERT_EQ(second.layers.layers.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    for (int r = 0; r < map.elevation.rows; ++r) {
      for (int c = 0; c < map.elevation.cols; ++c) {
        const float a = first.layers.layers[i](r, c), b = second.layers.layers[i](r, c);
        ASSERT_TRUE((std::isnan(a) && std::isnan(b)) || a == b);
      }
    }
  }
  ElevationMap changed = map;
  changed.elevation = map.elevation.clone();
  changed.elevation(10, 10) += 0.01f;
  EXPECT_NE(cache_key(changed, radii), cache_key(map, radii));
  EXPECT_NE(cache_key(map, {0.5, 1.5}), cache_key(map, radii));
  std::filesystem::remove_all(directory);
}

}  // namespace
