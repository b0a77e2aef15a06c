// Benchmarks for the "Measured" figures, on one core (cv::setNumThreads(1)):
//  - EMOI layers of a 2000 x 2000 DSM (0.1 m) at radii 5, 10, 15 m by DFT, and the direct eq. 7
//    loop on a crop, extrapolated to the full map (counter full_map_s) for the ratio;
//  - one Markov update on 2000 x 2000 cells: motion (shift + blur) and sensor update, for both
//    sensor models, with the plain Gaussian blur as the baseline of the box-pass blur, and with the
//    odometry-distortion hypotheses once the belief is concentrated.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <ctime>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "locd/emoi_markov/belief_assessment.hpp"
#include "locd/emoi_markov/emoi.hpp"
#include "locd/emoi_markov/local_elevation_map.hpp"
#include "locd/emoi_markov/markov_grid.hpp"
#include "locd/emoi_markov/masked_emoi.hpp"
#include "locd/emoi_markov/odometry_distortion.hpp"
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

// A local map as the robot has it after 15 m: the DSM around (row, col) within 25 m, seen along a
// 15 m drive in +x (a cell's travel mark: when the robot last had it within 20 m ahead), odometry
// recorded along the way. The DSM stands in for the laser.
LocalElevationMap driven_local_map(const ElevationMap& dsm, int row, int col) {
  LocalMapConfig config;
  config.resolution = dsm.geometry.resolution;
  config.size_m = 80.0;
  config.memory_distance_m = 10.0;
  LocalElevationMap map(config);
  const Eigen::Vector2d end = dsm.geometry.center_of(row, col);
  const double travel = 15.0;
  map.follow(end - Eigen::Vector2d(travel, 0.0));
  for (double t = 0.0; t <= travel + 1e-9; t += 0.05) map.record_pose(t, end - Eigen::Vector2d(travel - t, 0.0));
  map.follow(end);
  const int reach = static_cast<int>(25.0 / dsm.geometry.resolution);
  for (int r = row - reach; r <= row + reach; ++r) {
    for (int c = col - reach; c <= col + reach; ++c) {
      const Eigen::Vector2d p = dsm.geometry.center_of(r, c);
      if ((p - end).norm() > 25.0 || (p.x() < end.x() && p.y() > end.y())) continue;  // a quarter not seen
      const double seen = std::clamp(travel - (end.x() - p.x()) + 2.0, travel - 9.0, travel);
      map.insert_point({p.x(), p.y(), dsm.elevation(r, c)}, seen);
    }
  }
  return map;
}

// One masked update as the localizer runs it. with_motion: the motion update (15 m, 10 %) before
// and the belief summary after (the whole Markov update). distortion_nodes > 1: the belief starts
// concentrated (N(truth, 1 m)) so the odometry-distortion hypotheses run on its support, each
// rebuilding the robot's patch from the local map, and the sparse sensor model is used (no
// whole-map DFT match); otherwise the belief is uniform (global) and the DFT match runs.
void masked_update(benchmark::State& state, bool with_motion, int distortion_nodes,
                   double shape_sigma_m = SensorModelConfig{}.shape_sigma_m) {
  const ElevationMap& dsm = world_dsm();
  static const MaskedEmoiMatcher matcher(dsm, {5.0, 10.0, 15.0}, 0.5, SensorModelConfig{}.shape_edge_step_m);
  const int row = 1000, col = 1000;
  static const LocalElevationMap local_map = driven_local_map(dsm, row, col);
  MarkovGrid grid(dsm.geometry, cv::Mat_<uchar>(dsm.elevation.size(), uchar(1)));
  SensorModelConfig sensor;
  sensor.shape_sigma_m = shape_sigma_m;
  DistortionConfig distortion;
  distortion.nodes = distortion_nodes;
  const auto hypotheses = distortion_hypotheses(distortion.scale_stddev, distortion.direction_stddev_rad, distortion.nodes);
  const Eigen::Vector2d position = dsm.geometry.center_of(row, col), shift(15.0, 0.0);
  const double ground = dsm.elevation(row, col);
  double max_correction = 0.0;
  for (const auto& h : hypotheses) max_correction = std::max(max_correction, (h.transform - Eigen::Matrix2d::Identity()).norm());
  const double reach = local_map.patch_reach_m(position, matcher.cell_m(), matcher.patch_radius(), max_correction);
  const cv::Mat_<float> patch = robot_patch(matcher, row / matcher.factor(), col / matcher.factor());
  size_t cells = 0;
  for (auto _ : state) {
    state.PauseTiming();
    if (distortion_nodes > 1) grid.set_gaussian(position - shift, 1.0);
    state.ResumeTiming();
    const cv::Mat_<float> previous = distortion_nodes > 1 ? matcher.pool(grid.belief(), grid.occupied()) : cv::Mat_<float>();
    const double blur = std::hypot(0.1 * shift.norm(), 0.2);
    if (with_motion) grid.motion_update(shift, blur);
    bool sparse_done = false;
    if (distortion_nodes > 1) {
      // As the localizer: the remembered cells once, binned per hypothesis; the sparse model on
      // the prior's support.
      const PatchBinner binner(local_map.patch_cells(position, reach, 15.0), 0.0, matcher.cell_m(),
                               matcher.patch_radius(), ground, max_correction);
      const SupportLikelihood sparse = support_likelihood(
          matcher, [&](const Eigen::Matrix2d& b) { return binner.patch(b); }, hypotheses, distortion, sensor,
          previous, matcher.pool(grid.belief(), grid.occupied()), shift,
          residual_blur_m(distortion, blur, shift.norm(), 0.2));
      cells = sparse.cells.size();
      if (!sparse.cells.empty()) {
        cv::Rect window;
        const cv::Mat_<float> values =
            support_likelihood_on_grid(matcher, sparse, dsm.geometry.height, dsm.geometry.width, window);
        grid.sensor_update_likelihood(values, window, sparse.outside);
        sparse_done = true;
      }
    }
    if (!sparse_done) {
      const auto match = matcher.match(patch);
      cv::Mat_<float> coarse = matcher.coarse_log_likelihood(match, sensor);
      cv::exp(coarse, coarse);
      grid.sensor_update_likelihood(matcher.to_fine(coarse, dsm.geometry.height, dsm.geometry.width));
    }
    if (with_motion) {
      auto summary = grid.summary();
      benchmark::DoNotOptimize(summary);
      // The localization state and the estimate (belief_assessment.hpp), after every update.
      auto assessment = assess_belief(grid.belief(), grid.occupied(), grid.geometry(), AssessmentConfig{});
      benchmark::DoNotOptimize(assessment);
    }
  }
  state.counters["cells"] = static_cast<double>(dsm.geometry.size());
  if (distortion_nodes > 1) state.counters["hypothesis_cells"] = static_cast<double>(cells);
}

void BM_SensorUpdateMasked(benchmark::State& state) { masked_update(state, false, 1); }
BENCHMARK(BM_SensorUpdateMasked)->Unit(benchmark::kMillisecond);

// One whole Markov update as the localizer runs it from a uniform belief (motion, masked sensor
// update, summary): the global case, where the distortion hypotheses do not run.
void BM_MarkovUpdate(benchmark::State& state) { masked_update(state, true, 1); }
BENCHMARK(BM_MarkovUpdate)->Unit(benchmark::kMillisecond);

// The same once the belief is concentrated, with the 5 x 5 distortion hypotheses and the shape
// term (the defaults).
void BM_MarkovUpdateWithDistortion(benchmark::State& state) { masked_update(state, true, 5); }
BENCHMARK(BM_MarkovUpdateWithDistortion)->Unit(benchmark::kMillisecond);

// The same without the shape term (shape_sigma_m: 0): what the term costs.
void BM_MarkovUpdateWithDistortionEmoiOnly(benchmark::State& state) { masked_update(state, true, 5, 0.0); }
BENCHMARK(BM_MarkovUpdateWithDistortionEmoiOnly)->Unit(benchmark::kMillisecond);

// The localization state alone (modes, entropy, peak mass and the estimate) on a uniform belief
// (2000 x 2000 cells: the first updates) and on a concentrated one (N(x, 1 m)).
void BM_BeliefAssessment(benchmark::State& state) {
  const ElevationMap& dsm = world_dsm();
  MarkovGrid grid(dsm.geometry, cv::Mat_<uchar>(dsm.elevation.size(), uchar(1)));
  if (state.range(0) == 1) grid.set_gaussian(dsm.geometry.center_of(1000, 1000), 1.0);
  for (auto _ : state) {
    auto assessment = assess_belief(grid.belief(), grid.occupied(), grid.geometry(), AssessmentConfig{});
    benchmark::DoNotOptimize(assessment);
  }
  state.SetLabel(state.range(0) == 1 ? "concentrated" : "uniform");
}
BENCHMARK(BM_BeliefAssessment)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
