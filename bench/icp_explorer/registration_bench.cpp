// Registration of a full-size scan to the model: the modified ICP with its rejection rules on
// and off, and PCL's IterativeClosestPoint on the same pair (raw scan, and the same downsampled
// scan ours uses), in the same run. Counters: iterations, final error (cm, deg), points.
#include <benchmark/benchmark.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>

#include "four_rooms_pair.hpp"
#include "locd/icp_explorer/modified_icp.hpp"

namespace ie = locd::icp_explorer;
using locd::bench::RegistrationPair;

namespace {

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
    result = ie::register_scan(source, p.model, p.initial, rejector, settings);
    points = source.size();
    benchmark::DoNotOptimize(result);
  }
  report(state, result.T_map_base, result.iterations, static_cast<double>(points));
  state.counters["scan_points"] = static_cast<double>(p.scan.points.size());
  state.counters["model_points"] = static_cast<double>(p.model.size());
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
BENCHMARK_CAPTURE(BM_PclIcp, raw_scan, false)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_PclIcp, downsampled_scan, true)->Unit(benchmark::kMillisecond)->Iterations(3);

BENCHMARK_MAIN();
