// The paper's hall, end to end from rendered 640 x 480 frames (blur, threshold, Hough, eq. 1-3)
// through the particle filter; each benchmark runs once and reports its figures as counters.
//   BM_PaperRoute/particles    initial pose given, the route W1..W7..W1 (about 134 m), 5 runs
//                              like the paper: mean and max error at the waypoints, and the same
//                              for dead reckoning (odometry alone) as the baseline
//   BM_UnknownStart            no initial pose, 20 seeded runs starting at W1..W7: share of runs
//                              whose error is below 0.2 m within 60 s of driving (and stays so)
//   BM_Kidnapping              initial pose given, after 60 s the robot is teleported 20 m;
//                              share of 10 runs recovered (error < 0.2 m, staying) within 60 s
// Run: build/bench/ceiling_pf_hall_bench   (a few minutes on one core)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <numeric>
#include <opencv2/core.hpp>

#include "hall_setup.hpp"

using namespace locd;
using namespace locd::ceiling_pf;
namespace simc = locd::sim::ceiling;

namespace {

const bench::Hall& hall() {
  static const bench::Hall h;
  return h;
}

struct Trace {
  std::vector<double> waypoint_errors, dead_reckoning_errors;
  std::vector<std::pair<double, double>> errors;  // t, position error (once there is an estimate)
  double update_ms_sum = 0.0;
  size_t updates = 0;
  size_t max_particles = 0;
};

struct DriveOptions {
  simc::DriveConfig route;
  uint64_t seed = 1;
  double duration = 1e9;
  std::optional<Pose2> initial_pose;  // nullopt: unknown start
  ParticleFilterConfig filter;
  double kidnap_at = -1.0;
  Eigen::Vector2d kidnap_by = Eigen::Vector2d::Zero();
};

Trace drive(const DriveOptions& o) {
  simc::HallDrive run(o.route, *hall().renderer, o.seed);
  CeilingDetector detector{DetectorConfig{}};
  CeilingParticleFilter filter(o.filter, hall().index, VelocityMotionModel());
  if (o.initial_pose) {
    filter.set_pose(*o.initial_pose, Eigen::Vector3d(0.05, 0.05, 0.02).cwiseAbs2().asDiagonal());
  } else {
    filter.set_unknown();
  }
  Trace trace;
  std::optional<Pose2> last_odometry, first_odometry;
  int64_t last_stamp = 0;
  const Pose2 start = run.truth().pose;
  bool kidnapped = false;
  while (auto e = run.next(o.duration)) {
    if (o.kidnap_at > 0 && !kidnapped && e->t >= o.kidnap_at) {
      // Teleport by |kidnap_by|, turning its direction until the robot lands inside the hall.
      const Pose2 t = run.truth().pose;
      const Eigen::Vector2d size = hall().world->config().size;
      for (int k = 0; k < 36; ++k) {
        const Eigen::Vector2d to = Eigen::Vector2d(t.x, t.y) + Eigen::Rotation2Dd(k * M_PI / 18) * o.kidnap_by;
        if (to.x() > 3 && to.y() > 3 && to.x() < size.x() - 3 && to.y() < size.y() - 3) {
          run.teleport(Pose2(to.x(), to.y(), t.theta));
          break;
        }
      }
      kidnapped = true;
      continue;
    }
    Pose2 odometry_pose;
    if (const auto* odom = std::get_if<Odometry>(&e->measurement)) {
      const Pose2 p = Pose2::from_isometry(odom->pose);
      if (!first_odometry) first_odometry = p;
      if (last_odometry) filter.predict(velocity_between(*last_odometry, p, 1e-9 * (odom->header.stamp_ns - last_stamp)));
      last_odometry = p;
      last_stamp = odom->header.stamp_ns;
    } else if (const auto* img = std::get_if<Image>(&e->measurement)) {
      const auto t0 = std::chrono::steady_clock::now();
      const cv::Mat mono(img->height, img->width, CV_8UC1, const_cast<uint8_t*>(img->data.data()));
      std::vector<Detection> z;
      for (const auto& p : detector.detect_points(mono, *hall().camera)) z.push_back(Detection::from_point(p));
      filter.correct(z);
      trace.update_ms_sum += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      ++trace.updates;
      trace.max_particles = std::max(trace.max_particles, filter.particles().size());
    }
    const auto est = filter.estimate();
    if (!est) continue;
    const double error = std::hypot(est->pose.x - e->truth.x, est->pose.y - e->truth.y);
    trace.errors.push_back({e->t, error});
    if (e->reached_waypoint >= 0) {
      trace.waypoint_errors.push_back(error);
      if (first_odometry && last_odometry) {
        const Pose2 dead = start * (first_odometry->inverse() * *last_odometry);
        trace.dead_reckoning_errors.push_back(std::hypot(dead.x - e->truth.x, dead.y - e->truth.y));
      }
    }
  }
  return trace;
}

// First time from which the error stays below `threshold` until `until`; -1 if never.
double settled_time(const Trace& t, double threshold, double from, double until) {
  double settled = -1.0;
  for (const auto& [time, error] : t.errors) {
    if (time < from || time > until) continue;
    if (error < threshold) {
      if (settled < 0) settled = time;
    } else {
      settled = -1.0;
    }
  }
  return settled;
}

double mean(const std::vector<double>& v) { return v.empty() ? NAN : std::accumulate(v.begin(), v.end(), 0.0) / v.size(); }

simc::DriveConfig route_from(int first_waypoint) {
  simc::DriveConfig route;
  std::vector<Eigen::Vector2d> w = simc::paper_waypoints();
  std::rotate(w.begin(), w.begin() + first_waypoint, w.end());
  route.waypoints = w;
  return route;
}

void BM_PaperRoute(benchmark::State& state) {
  std::vector<double> errors, dead;
  double update_ms = 0.0;
  size_t updates = 0;
  for (auto _ : state) {
    for (uint64_t run = 1; run <= 5; ++run) {
      DriveOptions o;
      o.seed = run;
      o.filter = hall().filter_config();
      o.filter.kld_sampling = false;
      o.filter.particles = static_cast<size_t>(state.range(0));
      o.filter.seed = run;
      simc::HallDrive probe(o.route, *hall().renderer, run);
      o.initial_pose = probe.truth().pose;
      const Trace t = drive(o);
      errors.insert(errors.end(), t.waypoint_errors.begin(), t.waypoint_errors.end());
      dead.insert(dead.end(), t.dead_reckoning_errors.begin(), t.dead_reckoning_errors.end());
      update_ms += t.update_ms_sum;
      updates += t.updates;
    }
  }
  state.counters["waypoints"] = static_cast<double>(errors.size());
  state.counters["mean_waypoint_error_m"] = mean(errors);
  state.counters["max_waypoint_error_m"] = errors.empty() ? NAN : *std::max_element(errors.begin(), errors.end());
  state.counters["dead_reckoning_mean_error_m"] = mean(dead);
  state.counters["paper_mean_error_m"] = 0.066;
  state.counters["frame_ms_detect_and_update"] = update_ms / static_cast<double>(std::max<size_t>(updates, 1));
}
BENCHMARK(BM_PaperRoute)->ArgName("particles")->Arg(200)->Arg(1000)->Iterations(1)->Unit(benchmark::kSecond);

void BM_UnknownStart(benchmark::State& state) {
  int converged = 0, runs = 0;
  std::vector<double> times;
  size_t max_particles = 0;
  for (auto _ : state) {
    for (uint64_t seed = 1; seed <= 20; ++seed) {
      DriveOptions o;
      o.route = route_from(static_cast<int>(seed % 7));
      o.seed = 100 + seed;
      o.duration = 90.0;
      o.filter = hall().filter_config();
      o.filter.seed = seed;
      const Trace t = drive(o);
      const double settled = settled_time(t, 0.2, 0.0, 90.0);
      ++runs;
      if (settled >= 0.0 && settled <= 60.0) {
        ++converged;
        times.push_back(settled);
      }
      max_particles = std::max(max_particles, t.max_particles);
    }
  }
  state.counters["runs"] = runs;
  state.counters["converged_within_60s"] = converged;
  state.counters["share"] = static_cast<double>(converged) / std::max(runs, 1);
  state.counters["mean_time_to_converge_s"] = mean(times);
  state.counters["max_particles"] = static_cast<double>(max_particles);
}
BENCHMARK(BM_UnknownStart)->Iterations(1)->Unit(benchmark::kSecond);

void BM_Kidnapping(benchmark::State& state) {
  int recovered = 0, runs = 0;
  std::vector<double> times;
  for (auto _ : state) {
    for (uint64_t seed = 1; seed <= 10; ++seed) {
      DriveOptions o;
      o.route = route_from(static_cast<int>(seed % 7));
      o.seed = 200 + seed;
      o.duration = 150.0;
      o.filter = hall().filter_config();
      o.filter.seed = seed;
      simc::HallDrive probe(o.route, *hall().renderer, o.seed);
      o.initial_pose = probe.truth().pose;
      o.kidnap_at = 60.0;
      const double angle = 2.0 * M_PI * static_cast<double>(seed) / 10.0;
      o.kidnap_by = 20.0 * Eigen::Vector2d(std::cos(angle), std::sin(angle));
      const Trace t = drive(o);
      const double settled = settled_time(t, 0.2, 60.0, 150.0);
      ++runs;
      if (settled >= 0.0 && settled <= 120.0) {
        ++recovered;
        times.push_back(settled - 60.0);
      }
    }
  }
  state.counters["runs"] = runs;
  state.counters["recovered_within_60s"] = recovered;
  state.counters["mean_time_to_recover_s"] = mean(times);
}
BENCHMARK(BM_Kidnapping)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
