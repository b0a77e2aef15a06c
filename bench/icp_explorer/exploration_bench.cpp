// Exploration of the four-room world to the target coverage: next-best-view (layered hexahedral
// map, eq. 2-4) versus the nearest-frontier baseline, same world, seeds, odometry error and
// registration, in the same run. One iteration each (an exploration is a whole mission).
// Counters: scans to 90 / 95 % coverage, final coverage, path, registration error, and the
// model's size and ghost voxels (farther than 0.15 m from every static surface: people).
#include <benchmark/benchmark.h>

#include "exploration_run.hpp"

namespace {

constexpr double kTargetCoverage = 0.95;
constexpr int kMaxScans = 40;

const locd::sim::IndoorWorld& world() {
  static const locd::sim::IndoorWorld w =
      locd::sim::IndoorWorld::load(locd::bench::source_dir() + "/config/maps/four_rooms_3d.yaml");
  return w;
}

const locd::sim::SurfaceCoverage& reference() {
  static const locd::sim::SurfaceCoverage c = [] {
    // Scans from every free, reachable metre (a 0.5 m grid, every other point scanned), with the
    // mission's scanner: the observable static surface.
    locd::sim::Scanner3DConfig dense;
    return locd::sim::SurfaceCoverage(world(), dense, 0.2, 0.5, 0.3, Eigen::Vector2d(3.0, 3.0), 2);
  }();
  return c;
}

void BM_Explore(benchmark::State& state, locd::bench::Strategy strategy, bool carve_free_space) {
  const uint64_t seed = static_cast<uint64_t>(state.range(0));
  locd::bench::ExplorationRun run;
  for (auto _ : state)
    run = locd::bench::explore(strategy, seed, kMaxScans, kTargetCoverage, reference(), world(), carve_free_space);
  state.counters["scans_to_95"] = run.scans_to_target;
  state.counters["scans_to_90"] = run.scans_to_90;
  state.counters["scans"] = run.scans;
  state.counters["done"] = run.done ? 1.0 : 0.0;
  state.counters["coverage"] = run.coverage;
  state.counters["path_m"] = run.path_length;
  state.counters["max_error_cm"] = run.max_error_cm;
  state.counters["max_error_deg"] = run.max_error_deg;
  state.counters["model_voxels"] = static_cast<double>(run.model_voxels);
  state.counters["ghost_voxels"] = static_cast<double>(run.ghost_voxels);
  state.counters["reference_voxels"] = static_cast<double>(reference().reference_voxels());
  state.counters["reference_positions"] = static_cast<double>(reference().reachable_positions().size());
}

}  // namespace

BENCHMARK_CAPTURE(BM_Explore, next_best_view, locd::bench::Strategy::kNextBestView, true)
    ->DenseRange(1, 5)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK_CAPTURE(BM_Explore, nearest_frontier, locd::bench::Strategy::kNearestFrontier, true)
    ->DenseRange(1, 5)->Iterations(1)->Unit(benchmark::kSecond);
// The model without ghost carving (people's ghosts stay), for the ghost_voxels counter.
BENCHMARK_CAPTURE(BM_Explore, next_best_view_no_carving, locd::bench::Strategy::kNextBestView, false)
    ->DenseRange(1, 5)->Iterations(1)->Unit(benchmark::kSecond);

BENCHMARK_MAIN();
