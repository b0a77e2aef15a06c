// Memory of grid_mcl sessions on one map (the warehouse, 2120 x 2120 cells), measured as heap in
// use (glibc mallinfo2: small and mmapped blocks) around the Localizers' creation in one process:
// one session (configure: map, distance field, particles), then 99 more on the same map, each
// given the start pose and 6 s of the drive (150 scans: tracking, the set down to about
// min_particles).
//   per_session = (heap with 100 sessions - heap with 1) / 99
//   shared_map  = heap with 1 session - heap before - per_session
// and, for comparison, what the structures themselves count (SharedMap::memory_bytes,
// GridParticleFilter::memory_bytes).
// Run: build/bin/grid_mcl_memory_bench
#include <benchmark/benchmark.h>
#include <malloc.h>

#include <memory>

#include "locd/sim_grid_mcl/scenario_runs.hpp"

namespace {

using namespace locd;

size_t heap_in_use() {
  const struct mallinfo2 m = mallinfo2();
  return m.uordblks + m.hblkhd;
}

void BM_SessionsOnOneMap(benchmark::State& state) {
  const sim::Scenario scenario = sim::load_scenario(std::string(LOCD_SOURCE_DIR) + "/config/scenarios/warehouse.yaml");
  PluginContext context;
  context.maps = MapResolver(scenario.map_directories);
  sim::Simulation simulation(scenario, 1, 6.0);
  std::vector<Measurement> measurements;
  while (auto m = simulation.next()) measurements.push_back(m->measurement);
  const PoseEstimate start = simulation.initial_pose();
  const auto session = [&] {
    auto localizer = std::make_unique<grid_mcl::GridMclLocalizer>();
    localizer->configure(context, scenario.localizer.params);
    localizer->set_pose(start);
    for (const Measurement& m : measurements) localizer->update(m);
    return localizer;
  };
  std::vector<std::unique_ptr<grid_mcl::GridMclLocalizer>> sessions;
  size_t before = 0, one = 0, hundred = 0;
  for (auto _ : state) {
    sessions.clear();
    malloc_trim(0);
    before = heap_in_use();
    sessions.push_back(session());
    one = heap_in_use();
    for (int i = 1; i < 100; ++i) sessions.push_back(session());
    hundred = heap_in_use();
  }
  const double per_session = static_cast<double>(hundred - one) / 99.0;
  state.counters["sessions"] = 100;
  state.counters["heap_100_sessions_MB"] = static_cast<double>(hundred - before) / 1e6;
  state.counters["per_session_kB"] = per_session / 1e3;
  state.counters["shared_map_MB"] = (static_cast<double>(one - before) - per_session) / 1e6;
  state.counters["shared_map_counted_MB"] = static_cast<double>(sessions[0]->filter().map().memory_bytes()) / 1e6;
  state.counters["session_counted_kB"] = static_cast<double>(sessions[0]->filter().memory_bytes()) / 1e3;
  state.counters["particles_per_session"] = static_cast<double>(sessions[0]->filter().particles().size());
  state.counters["maps_loaded"] = static_cast<double>(grid_mcl::shared_maps_alive());
}
BENCHMARK(BM_SessionsOnOneMap)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
