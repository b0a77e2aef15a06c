// grid_mcl's time per filter update, and MRPT's pf-localization on the same simulated run.
//
//   BM_Update/model/particles/threads   one filter update (motion sampling of every particle,
//        weighting, KLD low-variance resampling, cluster estimate, localization state) on the
//        corridor grid's scans (541 beams, max_beams 60: 61 beams by AMCL's step), the particle
//        count held fixed (min = max), every scan an update. model 0: likelihood_field (AMCL's
//        1 + sum pz^3), 1: likelihood_field_prob (the product, as MRPT's likelihood field).
//        CPU time per iteration = per update.
//   BM_VersusMrpt/particles   the corridor grid run (seed 7, 60 s) exported as an MRPT rawlog
//        (locsim's exporter: CARMEN log -> carmen2rawlog), the map converted by
//        ros-map-yaml2mrpt, and MRPT's pf-localization (Debian mrpt-apps) run on one core
//        (taskset -c 0) with a fixed particle count, its likelihood-field model (LF_Trun, the
//        product over beams, decimation 9 -> 61 beams, stdHit 0.1, zHit 0.95, zRandom 0.05),
//        systematic resampling every step, the start uniform in +-0.5 m, +-10 deg; grid_mcl on the
//        same scans in-process with likelihood_field_prob and the same settings, updating on every
//        scan like MRPT. Counters: mean update time of each (MRPT: its exec_times.txt), their
//        ratio, and the RMSE of each against the truth after 10 s.
// Run: taskset -c 0 build/bin/grid_mcl_update_bench
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>

#include <numeric>

#include "locd/grid_mcl/grid_particle_filter.hpp"
#include "locd/sdk/plugin.hpp"
#include "locd/sdk/validate.hpp"
#include "locd/sim/scenario.hpp"
#include "locd/sim/simulation.hpp"
#include "locd/sim_grid_mcl/rawlog_export.hpp"

namespace {

using namespace locd;
using namespace locd::grid_mcl;
namespace fs = std::filesystem;

struct ScanStep {
  double t = 0.0;
  LaserScan scan;
  Pose2 odometry, truth;
};

const sim::Scenario& corridor() {
  static const sim::Scenario s = sim::load_scenario(std::string(LOCD_SOURCE_DIR) + "/config/scenarios/corridor_grid.yaml");
  return s;
}

// The scans of a run with the odometry pose and the truth at each.
std::vector<ScanStep> scan_steps(const sim::Scenario& scenario, uint64_t seed, double duration) {
  sim::Simulation simulation(scenario, seed, duration);
  std::vector<ScanStep> steps;
  std::optional<Pose2> odometry;
  while (auto m = simulation.next()) {
    validate(m->measurement);
    if (const auto* o = std::get_if<Odometry>(&m->measurement)) odometry = Pose2::from_isometry(o->pose);
    if (const auto* s = std::get_if<LaserScan>(&m->measurement); s && odometry) {
      steps.push_back({m->t, *s, *odometry, simulation.truth().at(m->t).pose});
    }
  }
  return steps;
}

std::shared_ptr<const SharedMap> corridor_map() {
  static const auto map = load_shared_map(
      corridor().map_file, [](const std::string& image) { return MapResolver(corridor().map_directories).resolve(image); },
      Limits{}.max_map_cells);
  return map;
}

Config bench_config(size_t particles, LaserModelType model, int threads) {
  Config c;
  c.motion = {0.01, 0.005, 0.005, 0.005, 0.0};
  c.laser.type = model;
  c.laser.max_beams = 60;
  c.laser.z_hit = 0.95;
  c.laser.z_rand = 0.05;
  c.laser.sigma_hit = 0.1;
  c.laser.max_range = 30.0;
  c.filter.min_particles = c.filter.max_particles = c.filter.global_particles = particles;
  c.filter.update_min_d = c.filter.update_min_a = 0.0;  // every scan
  c.filter.relocalize_after_lost_updates = 0;
  c.filter.threads = threads;
  return c;
}

void BM_Update(benchmark::State& state) {
  static const std::vector<ScanStep> steps = scan_steps(corridor(), 7, 30.0);
  const auto model = state.range(0) == 0 ? LaserModelType::kLikelihoodField : LaserModelType::kLikelihoodFieldProb;
  const size_t particles = static_cast<size_t>(state.range(1));
  GridParticleFilter filter(bench_config(particles, model, static_cast<int>(state.range(2))), corridor_map());
  filter.set_pose(steps[0].truth, Eigen::Vector3d(0.05, 0.05, 0.02).cwiseAbs2().asDiagonal());
  filter.correct(steps[0].scan, steps[0].odometry);
  size_t i = 1, beams = 0;
  double error = 0.0;
  for (auto _ : state) {
    const ScanStep& s = steps[i];
    const CorrectionReport r = filter.correct(s.scan, s.odometry);
    beams = r.beams;
    state.PauseTiming();
    const auto e = filter.estimate();
    error = std::max(error, std::hypot(e->pose.x - s.truth.x, e->pose.y - s.truth.y));
    if (++i == steps.size()) {  // around again from the start
      i = 1;
      filter.set_pose(steps[0].truth, Eigen::Vector3d(0.05, 0.05, 0.02).cwiseAbs2().asDiagonal());
      filter.correct(steps[0].scan, steps[0].odometry);
    }
    state.ResumeTiming();
  }
  state.counters["beams"] = static_cast<double>(beams);
  state.counters["particles"] = static_cast<double>(filter.particles().size());
  state.counters["max_error_m"] = error;
}
BENCHMARK(BM_Update)
    ->ArgNames({"model", "particles", "threads"})
    ->Args({0, 1000, 1})
    ->Args({0, 10000, 1})
    ->Args({0, 100000, 1})
    ->Args({1, 1000, 1})
    ->Args({1, 10000, 1})
    ->Args({1, 100000, 1})
    ->Args({0, 100000, 2})
    ->Unit(benchmark::kMillisecond);

// ------------------------------------------------------------------ MRPT

std::string mrpt_ini(const fs::path& dir, const fs::path& map, const fs::path& rawlog, size_t particles, const Pose2& start) {
  std::ostringstream s;
  s << "[KLD_options]\nKLD_binSize_PHI_deg=10\nKLD_binSize_XY=0.5\nKLD_delta=0.01\nKLD_epsilon=0.05\n"
    << "KLD_maxSampleSize=" << particles << "\nKLD_minSampleSize=" << particles << "\nKLD_minSamplesPerBin=0\n"
    << "[PF_options]\nPF_algorithm=0\nresamplingMethod=3\nadaptiveSampleSize=0\nBETA=1.1\nsampleSize=" << particles << "\n"
    << "[DummyOdometryParams]\nminStdXY=0.01\nminStdPHI=0.5\n"
    << "[LocalizationExperiment]\nuse_3D_poses=false\nmap_file=" << map.string() << "\nrawlog_file=" << rawlog.string()
    << "\nlogOutput_dir=" << (dir / "out").string() << "\n3DSceneFrequency=-1\nexperimentRepetitions=1\nparticles_count="
    << particles << "\ninit_PDF_mode=1\ninit_PDF_min_x=" << start.x - 0.5 << "\ninit_PDF_max_x=" << start.x + 0.5
    << "\ninit_PDF_min_y=" << start.y - 0.5 << "\ninit_PDF_max_y=" << start.y + 0.5
    << "\ninit_PDF_min_yaw_deg=" << start.theta * 180 / M_PI - 10 << "\ninit_PDF_max_yaw_deg=" << start.theta * 180 / M_PI + 10
    << "\nSHOW_PROGRESS_3D_REAL_TIME=false\n"
    << "[MetricMap]\noccupancyGrid_count=1\ngasGrid_count=0\nlandmarksMap_count=0\npointsMap_count=0\nbeaconMap_count=0\n"
    << "likelihoodMapSelection=-1\n[MetricMap_occupancyGrid_00_creationOpts]\nresolution=0.05\n"
    << "[MetricMap_occupancyGrid_00_likelihoodOpts]\nlikelihoodMethod=4\nLF_decimation=9\nLF_stdHit=0.1\n"
    << "LF_maxCorrsDistance=2.0\nLF_zHit=0.95\nLF_zRandom=0.05\nLF_maxRange=30\nLF_alternateAverageMethod=0\n"
    << "enableLikelihoodCache=false\n";
  return s.str();
}

struct MrptRun {
  std::vector<Pose2> estimates;  // one per scan
  std::vector<double> seconds;   // per update
};

MrptRun run_mrpt(const fs::path& dir, size_t particles, const Pose2& start) {
  const fs::path map_dir = dir / "map";
  fs::create_directories(map_dir);
  for (const char* ext : {".yaml", ".pgm"}) {
    fs::copy_file(fs::path(corridor().map_file).replace_extension(ext), map_dir / (std::string("corridor_grid") + ext),
                  fs::copy_options::overwrite_existing);
  }
  const fs::path log = dir / "mrpt.log";
  fs::remove(log);
  if (sim::grid::run_program({"ros-map-yaml2mrpt", "-w", "-q", "-i", (map_dir / "corridor_grid.yaml").string()}, log) != 0) {
    throw std::runtime_error("ros-map-yaml2mrpt failed (install mrpt-apps); see " + log.string());
  }
  const fs::path ini = dir / "pf.ini";
  std::ofstream(ini) << mrpt_ini(dir, map_dir / "corridor_grid.gridmap.gz", dir / "run.rawlog", particles, start);
  if (sim::grid::run_program({"taskset", "-c", "0", "pf-localization", ini.string()}, log) != 0) {
    throw std::runtime_error("pf-localization failed; see " + log.string());
  }
  MrptRun run;
  const std::regex estimate(R"(PDF estimation: \(([-0-9.]+),([-0-9.]+),([-0-9.]+)deg\))");
  std::ifstream in(log);
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_search(line, m, estimate)) {
      run.estimates.emplace_back(std::stod(m[1]), std::stod(m[2]), std::stod(m[3]) * M_PI / 180.0);
    }
  }
  char out_dir[64];
  std::snprintf(out_dir, sizeof out_dir, "out_000_%07zu", particles);
  std::ifstream times(dir / out_dir / "exec_times.txt");
  for (double v; times >> v;) run.seconds.push_back(v);
  return run;
}

double rmse_after(const std::vector<ScanStep>& steps, const std::vector<Pose2>& estimates, double from) {
  double sum = 0.0;
  size_t n = 0;
  for (size_t i = 0; i < steps.size() && i < estimates.size(); ++i) {
    if (steps[i].t < from) continue;
    sum += std::pow(estimates[i].x - steps[i].truth.x, 2) + std::pow(estimates[i].y - steps[i].truth.y, 2);
    ++n;
  }
  return n ? std::sqrt(sum / static_cast<double>(n)) : NAN;
}

void BM_VersusMrpt(benchmark::State& state) {
  const size_t particles = static_cast<size_t>(state.range(0));
  const fs::path dir = fs::temp_directory_path() / ("locd_grid_mcl_vs_mrpt_" + std::to_string(particles));
  fs::create_directories(dir);
  const uint64_t seed = 7;
  const double duration = 60.0;
  const sim::grid::RawlogExport exported = sim::grid::export_rawlog(corridor(), seed, duration, dir / "run.rawlog");
  const std::vector<ScanStep> steps = scan_steps(corridor(), seed, duration);
  if (steps.size() != exported.scans) throw std::runtime_error("the rawlog and the in-process run differ");
  MrptRun mrpt;
  std::vector<Pose2> ours;
  double ours_seconds = 0.0;
  for (auto _ : state) {
    mrpt = run_mrpt(dir, particles, steps[0].truth);
    GridParticleFilter filter(bench_config(particles, LaserModelType::kLikelihoodFieldProb, 1), corridor_map());
    filter.set_pose(steps[0].truth, Eigen::Vector3d(0.29, 0.29, 0.1).cwiseAbs2().asDiagonal());
    ours.clear();
    ours_seconds = 0.0;
    for (const ScanStep& s : steps) {
      const auto begin = std::chrono::steady_clock::now();
      filter.correct(s.scan, s.odometry);
      ours_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
      ours.push_back(filter.estimate_at(s.odometry)->pose);
    }
  }
  const double mrpt_ms = 1e3 * std::accumulate(mrpt.seconds.begin(), mrpt.seconds.end(), 0.0) /
                         static_cast<double>(std::max<size_t>(mrpt.seconds.size(), 1));
  const double ours_ms = 1e3 * ours_seconds / static_cast<double>(steps.size());
  state.counters["scans"] = static_cast<double>(steps.size());
  state.counters["mrpt_estimates"] = static_cast<double>(mrpt.estimates.size());
  state.counters["mrpt_update_ms"] = mrpt_ms;
  state.counters["grid_mcl_update_ms"] = ours_ms;
  state.counters["mrpt_over_grid_mcl"] = mrpt_ms / ours_ms;
  state.counters["mrpt_rmse_after_10s_m"] = rmse_after(steps, mrpt.estimates, 10.0);
  state.counters["grid_mcl_rmse_after_10s_m"] = rmse_after(steps, ours, 10.0);
}
BENCHMARK(BM_VersusMrpt)->ArgName("particles")->Arg(1000)->Arg(10000)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
