// Registration of a full-size scan to the model: the modified ICP with its rejection rules on
// and off, and PCL's IterativeClosestPoint on the same pair (raw scan, and the same downsampled
// scan ours uses), in the same run. Counters: iterations, final error (cm, deg), points. And the
// rules on versus off over 72 starts spread over the odometry bounds (BM_RulesSweep).
#include <benchmark/benchmark.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>

#include <algorithm>
#include <ctime>
#include <vector>

#include "four_rooms_pair.hpp"
#include "locd/icp_explorer/modified_icp.hpp"

namespace ie = locd::icp_explorer;
using locd::bench::RegistrationPair;

namespace {

double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

const RegistrationPair& pair() {
  static const RegistrationPair p = locd::bench::make_pair();
  return p;
}

ie::RejectionRules rules(bool on) {
  ie::RejectionRules r;
  r.intensity = r.overlap = r.error_length = r.error_direction = on;
  return r;
}

void report(benchmark::State& state, const Eigen::Isometry3d& estimate, double iterations, double points) {
  state.counters["iterations"] = iterations;
  state.counters["error_cm"] = 100.0 * locd::bench::translation_error(estimate, pair().truth);
  state.counters["error_deg"] = locd::bench::rotation_error_deg(estimate, pair().truth);
  state.counters["source_points"] = points;
}

// From the raw 100k-point cloud to the registered pose: downsampling included.
void BM_ModifiedIcp(benchmark::State& state, bool rules_on, ie::IcpMetric metric) {
  const RegistrationPair& p = pair();
  ie::IcpSettings settings;
  settings.metric = metric;
  const ie::CorrespondenceRejector rejector(rules(rules_on), ie::OdometryErrorBound{}, p.initial, p.scan.sensor_pose);
  ie::RegistrationResult result;
  size_t points = 0;
  for (auto _ : state) {
    const ie::ScanPoints source = ie::voxel_downsample(p.scan.points, p.scan.intensity, 0.3, p.scan.sensor_pose);
    result = ie::register_coarse_to_fine(source, p.model, &p.coarse_model, p.initial, rejector, settings);
    points = source.size();
    benchmark::DoNotOptimize(result);
  }
  report(state, result.T_map_base, result.iterations + result.coarse_iterations, static_cast<double>(points));
  state.counters["converged"] = result.converged;
  state.counters["scan_points"] = static_cast<double>(p.scan.points.size());
  state.counters["model_points"] = static_cast<double>(p.model.size());
}

// Rules on versus off (and the coarse stage on versus off) over many starts: the same pair registered from 72 odometry predictions
// spread over the bounds (0.2, 0.35 and 0.5 m in six directions, yaw off by +-5 and +-10 deg),
// the rejector built around each prediction as in the plugin. Counters: share of registrations
// within 2 cm and 0.2 deg, mean iterations, mean CPU ms per registration (downsampling
// included), worst error.
void BM_RulesSweep(benchmark::State& state, bool rules_on, ie::IcpMetric metric, bool coarse_stage = true) {
  const RegistrationPair& p = pair();
  ie::IcpSettings settings;
  settings.metric = metric;
  settings.coarse.enabled = coarse_stage;
  std::vector<Eigen::Isometry3d> starts;
  for (double t : {0.2, 0.35, 0.5})
    for (int a = 0; a < 6; ++a)
      for (double yaw_deg : {-10.0, -5.0, 5.0, 10.0})
        starts.push_back(p.truth * locd::Pose2(t * std::cos(a * M_PI / 3 + 0.3), t * std::sin(a * M_PI / 3 + 0.3),
                                               yaw_deg * M_PI / 180)
                                       .to_isometry());
  double successes = 0, iterations = 0, cpu_ms = 0, worst_cm = 0, worst_deg = 0, claimed = 0, claimed_wrongly = 0;
  for (auto _ : state) {
    successes = iterations = cpu_ms = worst_cm = worst_deg = claimed = claimed_wrongly = 0;
    for (const Eigen::Isometry3d& start : starts) {
      const double begin = thread_cpu_ms();
      const ie::CorrespondenceRejector rejector(rules(rules_on), ie::OdometryErrorBound{}, start, p.scan.sensor_pose);
      const ie::ScanPoints source = ie::voxel_downsample(p.scan.points, p.scan.intensity, 0.3, p.scan.sensor_pose);
      const ie::RegistrationResult r = ie::register_coarse_to_fine(source, p.model, &p.coarse_model, start, rejector, settings);
      cpu_ms += thread_cpu_ms() - begin;
      const double cm = 100.0 * locd::bench::translation_error(r.T_map_base, p.truth);
      const double deg = locd::bench::rotation_error_deg(r.T_map_base, p.truth);
      const bool success = cm <= 2.0 && deg <= 0.2;
      successes += success;
      claimed += r.converged;
      claimed_wrongly += r.converged && !success;
      iterations += r.iterations + r.coarse_iterations;
      worst_cm = std::max(worst_cm, cm);
      worst_deg = std::max(worst_deg, deg);
    }
  }
  const double n = static_cast<double>(starts.size());
  state.counters["starts"] = n;
  state.counters["success_rate"] = successes / n;
  state.counters["mean_iterations"] = iterations / n;
  state.counters["cpu_ms_per_registration"] = cpu_ms / n;
  state.counters["worst_error_cm"] = worst_cm;
  state.counters["worst_error_deg"] = worst_deg;
  state.counters["says_converged"] = claimed;
  state.counters["says_converged_wrongly"] = claimed_wrongly;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr to_pcl(const std::vector<Eigen::Vector3d>& points) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->reserve(points.size());
  for (const auto& p : points) cloud->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()),
                                                              static_cast<float>(p.z())));
  return cloud;
}

void BM_PclIcp(benchmark::State& state, bool downsampled) {
  const RegistrationPair& p = pair();
  std::vector<Eigen::Vector3d> scan;
  if (downsampled) {
    scan = ie::voxel_downsample(p.scan.points, {}, 0.3, p.scan.sensor_pose).points;
  } else {
    for (const auto& q : p.scan.points) scan.push_back(p.scan.sensor_pose * q.cast<double>());
  }
  const auto source = to_pcl(scan);
  const auto target = to_pcl(p.model.points());
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setInputTarget(target);
  icp.setInputSource(source);
  icp.setMaxCorrespondenceDistance(1.0);
  icp.setMaximumIterations(50);
  icp.setTransformationEpsilon(1e-8);
  icp.setEuclideanFitnessEpsilon(1e-8);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  Eigen::Isometry3d estimate = p.initial;
  for (auto _ : state) {
    icp.align(aligned, p.initial.matrix().cast<float>());
    estimate.matrix() = icp.getFinalTransformation().cast<double>();
  }
  report(state, estimate, 0.0, static_cast<double>(scan.size()));
  state.counters["converged"] = icp.hasConverged() ? 1.0 : 0.0;
}

}  // namespace

BENCHMARK_CAPTURE(BM_ModifiedIcp, rules_on_point_to_plane, true, ie::IcpMetric::kPointToPlane)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ModifiedIcp, rules_off_point_to_plane, false, ie::IcpMetric::kPointToPlane)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ModifiedIcp, rules_on_point_to_point, true, ie::IcpMetric::kPointToPoint)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ModifiedIcp, rules_off_point_to_point, false, ie::IcpMetric::kPointToPoint)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_RulesSweep, rules_on_point_to_plane, true, ie::IcpMetric::kPointToPlane)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_RulesSweep, rules_on_point_to_plane_one_resolution, true, ie::IcpMetric::kPointToPlane, false)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_RulesSweep, rules_off_point_to_plane, false, ie::IcpMetric::kPointToPlane)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_RulesSweep, rules_on_point_to_point, true, ie::IcpMetric::kPointToPoint)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_RulesSweep, rules_off_point_to_point, false, ie::IcpMetric::kPointToPoint)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_PclIcp, raw_scan, false)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_PclIcp, downsampled_scan, true)->Unit(benchmark::kMillisecond)->Iterations(3);

BENCHMARK_MAIN();
