// Benchmarks for the "Measured" figures, on one core (cv::setNumThreads(1)):
//  - EMOI layers of a 2000 x 2000 DSM (0.1 m) at radii 5, 10, 15 m by DFT, and the direct eq. 7
//    loop on a crop, extrapolated to the full map (counter full_map_s) for the ratio;
//  - one Markov update on 2000 x 2000 cells: motion (shift + blur) and sensor update, for both
//    sensor models, with the plain Gaussian blur as the baseline of the box-pass blur.
#include <benchmark/benchmark.h>

#include <ctime>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "locd/emoi_markov/emoi.hpp"
#include "locd/emoi_markov/local_elevation_map.hpp"
#include "locd/emoi_markov/markov_grid.hpp"
#include "locd/emoi_markov/masked_emoi.hpp"
#include "locd/sim_emoi_markov/synthetic_dsm.hpp"

namespace {

using namespace locd::emoi;

const ElevationMap& world_dsm() {
  static const ElevationMap dsm = [] {
    cv::setNumThreads(1);
    locd::sim::emoi::SyntheticDsmConfig config;  // 200 x 200 m at 0.1 m = 2000 x 2000 cells
    return locd::sim::emoi::noisy_dsm(locd::sim::emoi::generate_world(config, 1).surface, 0.05, 0.0, 1);
  }();
  return dsm;
}

ElevationMap crop(const ElevationMap& map, int side) {
  ElevationMap out;
  out.geometry = map.geometry;
  out.geometry.width = out.geometry.height = side;
  out.elevation = map.elevation(cv::Rect(0, 0, side, side)).clone();
  return out;
}

void BM_EmoiLayersFft(benchmark::State& state) {
  const ElevationMap& dsm = world_dsm();
  for (auto _ : state) {
    auto layers = emoi_fft(dsm, {5.0, 10.0, 15.0});
    benchmark::DoNotOptimize(layers);
  }
  state.counters["cells"] = static_cast<double>(dsm.geometry.size());
}
BENCHMARK(BM_EmoiLayersFft)->Unit(benchmark::kMillisecond)->Iterations(3);

// The direct loop for one radius on a crop; full_map_cpu_s = CPU time per cell * 2000^2.
void BM_EmoiDirectCrop(benchmark::State& state) {
  const double radius = static_cast<double>(state.range(0));
  const int side = static_cast<int>(state.range(1));
  const ElevationMap part = crop(world_dsm(), side);
  double seconds = 0.0;
  for (auto _ : state) {
    const std::clock_t start = std::clock();  // process CPU time, like the CPU column
    auto layer = emoi_direct(part, radius);
    benchmark::DoNotOptimize(layer);
    seconds += static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
  }
  const double per_cell = seconds / static_cast<double>(state.iterations()) / (static_cast<double>(side) * side);
  state.counters["full_map_cpu_s"] = per_cell * static_cast<double>(world_dsm().geometry.size());
}
BENCHMARK(BM_EmoiDirectCrop)->Args({5, 250})->Unit(benchmark::kMillisecond)->Iterations(1);

// The FFT on the same crop and radius, for a like-for-like ratio.
void BM_EmoiFftCrop(benchmark::State& state) {
  const ElevationMap part = crop(world_dsm(), static_cast<int>(state.range(1)));
  for (auto _ : state) {
    auto layers = emoi_fft(part, {static_cast<double>(state.range(0))});
    benchmark::DoNotOptimize(layers);
  }
}
BENCHMARK(BM_EmoiFftCrop)->Args({5, 250})->Unit(benchmark::kMillisecond);

// A robot patch as the localizer builds it: the DSM around a cell, with a missing sector.
cv::Mat_<float> robot_patch(const MaskedEmoiMatcher& matcher, int row, int col) {
  const int radius = matcher.patch_radius();
  const auto& coarse = matcher.surface().elevation;
  cv::Mat_<float> patch(2 * radius + 1, 2 * radius + 1, std::numeric_limits<float>::quiet_NaN());
  const float centre = coarse(row, col);
  for (int i = -radius; i <= radius; ++i) {
    for (int j = -radius; j <= radius; ++j) {
      if (j < 0 && i < 0) continue;  // a quarter the robot has not seen
      patch(i + radius, j + radius) = coarse(row + i, col + j) - centre;
    }
  }
  return patch;
}

void BM_MotionUpdate(benchmark::State& state) {
  const ElevationMap& dsm = world_dsm();
  MarkovGrid grid(dsm.geometry, cv::Mat_<uchar>(dsm.elevation.size(), uchar(1)));
  for (auto _ : state) {
    auto report = grid.motion_update({15.0, 3.3}, 1.5);  // 15 m, 10 % error
    benchmark::DoNotOptimize(report);
  }
}
BENCHMARK(BM_MotionUpdate)->Unit(benchmark::kMillisecond);

// Baseline: the same blur as one plain Gaussian convolution (separable, 91-tap kernels).
void BM_MotionBlurPlainGaussian(benchmark::State& state) {
  const ElevationMap& dsm = world_dsm();
  cv::Mat_<float> belief(dsm.elevation.size(), 1.0f / static_cast<float>(dsm.geometry.size()));
  for (auto _ : state) {
    cv::GaussianBlur(belief, belief, cv::Size(91, 91), 15.0, 15.0, cv::BORDER_CONSTANT);
    benchmark::DoNotOptimize(belief);
  }
}
BENCHMARK(BM_MotionBlurPlainGaussian)->Unit(benchmark::kMillisecond);

void BM_SensorUpdateMasked(benchmark::State& state) {
  const ElevationMap& dsm = world_dsm();
  static const MaskedEmoiMatcher matcher(dsm, {5.0, 10.0, 15.0}, 0.5);
  MarkovGrid grid(dsm.geometry, cv::Mat_<uchar>(dsm.elevation.size(), uchar(1)));
  SensorModelConfig sensor;
  const cv::Mat_<float> patch = robot_patch(matcher, 200, 200);
  for (auto _ : state) {
    const auto match = matcher.match(patch);
    const auto likelihood = matcher.likelihood(match, sensor, dsm.geometry.height, dsm.geometry.width);
    auto report = grid.sensor_update_likelihood(likelihood);
    benchmark::DoNotOptimize(report);
  }
}
BENCHMARK(BM_SensorUpdateMasked)->Unit(benchmark::kMillisecond);

void BM_SensorUpdateFullDisk(benchmark::State& state) {
  const ElevationMap& dsm = world_dsm();
  static const EmoiLayers layers = to_layers({5.0, 10.0, 15.0}, emoi_fft(dsm, {5.0, 10.0, 15.0}));
  MarkovGrid grid(dsm.geometry, layers_support(layers));
  SensorModelConfig sensor;
  EmoiObservation z{{layers.layers[0](1000, 1000), layers.layers[1](1000, 1000), layers.layers[2](1000, 1000)},
                    {1.0, 1.0, 1.0}};
  for (auto _ : state) {
    auto report = grid.sensor_update(full_disk_log_likelihood(layers, z, sensor), sensor.min_likelihood);
    benchmark::DoNotOptimize(report);
  }
}
BENCHMARK(BM_SensorUpdateFullDisk)->Unit(benchmark::kMillisecond);

// One whole Markov update as the localizer runs it (motion, masked sensor update, summary).
void BM_MarkovUpdate(benchmark::State& state) {
  const ElevationMap& dsm = world_dsm();
  static const MaskedEmoiMatcher matcher(dsm, {5.0, 10.0, 15.0}, 0.5);
  MarkovGrid grid(dsm.geometry, cv::Mat_<uchar>(dsm.elevation.size(), uchar(1)));
  SensorModelConfig sensor;
  const cv::Mat_<float> patch = robot_patch(matcher, 200, 200);
  for (auto _ : state) {
    grid.motion_update({15.0, 3.3}, 1.5);
    const auto match = matcher.match(patch);
    grid.sensor_update_likelihood(matcher.likelihood(match, sensor, dsm.geometry.height, dsm.geometry.width));
    auto summary = grid.summary();
    benchmark::DoNotOptimize(summary);
  }
  state.counters["cells"] = static_cast<double>(dsm.geometry.size());
}
BENCHMARK(BM_MarkovUpdate)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
