// feature_ekf speed on one core: 361-beam scans (180 deg at 0.5 deg, 1 cm noise) ray-cast in the
// corridor world config/maps/corridor.yaml from 40 poses around its loop. Extraction, association
// + update, and the two together are timed separately; items/s = scans/s. Then what the plugin
// adds (issue 15): the scan's agreement with the map, the whole monitored update as the plugin
// runs it while tracking, and one scan of the global search while lost (new hypotheses from line
// pairs, or tracking the hypotheses already made).
#include <benchmark/benchmark.h>

#include <memory>
#include <random>

#include "locd/feature_ekf/feature_ekf_filter.hpp"
#include "locd/feature_ekf/global_search.hpp"
#include "locd/feature_ekf/relocalizing_feature_ekf.hpp"
#include "locd/feature_ekf/scan_agreement.hpp"
#include "locd/sim/laser_scanner.hpp"

using namespace locd;
using namespace locd::feature_ekf;

namespace {

struct Corridor {
  FeatureMap2D map;
  std::vector<Pose2> poses;
  std::vector<LaserScan> scans;
  std::vector<ExtractedFeatures> features;
};

// Poses on the corridor's centre line (1 m from the outer walls), heading along the loop.
const Corridor& corridor() {
  static const Corridor c = [] {
    Corridor world;
    world.map = load_feature_map(LOCD_CORRIDOR_MAP, 100000);
    const std::vector<Eigen::Vector2d> corners = {{1, 1}, {39, 1}, {39, 19}, {1, 19}};
    const double perimeter = 2 * (38 + 18);
    std::mt19937_64 rng(42);
    for (int i = 0; i < 40; ++i) {
      double s = perimeter * i / 40.0 + 0.37;
      for (int side = 0; side < 4; ++side) {
        const Eigen::Vector2d a = corners[side], b = corners[(side + 1) % 4];
        const double length = (b - a).norm();
        if (s > length) {
          s -= length;
          continue;
        }
        const Eigen::Vector2d p = a + (b - a) * (s / length);
        world.poses.emplace_back(p.x(), p.y(), std::atan2(b.y() - a.y(), b.x() - a.x()));
        break;
      }
    }
    const LaserFeatureExtractor extractor;
    sim::LaserScannerConfig laser;  // 361 beams over 180 deg, 1 cm noise
    laser.mount = Pose2(0.1, 0.0, 0.0);
    const sim::LaserScannerModel scanner(
        laser, std::make_shared<const sim::SegmentWorld>(sim::SegmentWorld::from_feature_map(world.map)));
    for (const Pose2& pose : world.poses) {
      world.scans.push_back(scanner.scan(pose, 0, rng));
      world.features.push_back(extractor.extract(world.scans.back()));
    }
    return world;
  }();
  return c;
}

// A predicted pose a few centimetres off the truth, with the covariance a prediction has.
void reset_near_truth(FeatureEkfFilter& filter, const Pose2& truth) {
  filter.set_pose({truth.x + 0.03, truth.y - 0.02, truth.theta + 0.01},
                  Eigen::Vector3d(0.05 * 0.05, 0.05 * 0.05, 0.02 * 0.02).asDiagonal());
}

void BM_Extraction(benchmark::State& state) {
  const Corridor& world = corridor();
  const LaserFeatureExtractor extractor;
  size_t i = 0, features = 0;
  for (auto _ : state) {
    const ExtractedFeatures f = extractor.extract(world.scans[i++ % world.scans.size()]);
    features += f.lines.size() + f.corners.size() + f.edges.size();
    benchmark::DoNotOptimize(f);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["features_per_scan"] = static_cast<double>(features) / state.iterations();
}

void BM_AssociationAndUpdate(benchmark::State& state) {
  const Corridor& world = corridor();
  FeatureEkfFilter filter(FeatureEkfConfig{}, world.map);
  size_t i = 0, matched = 0;
  for (auto _ : state) {
    const size_t k = i++ % world.scans.size();
    reset_near_truth(filter, world.poses[k]);
    const ScanUpdateReport report = filter.update(world.features[k]);
    matched += report.matched[0] + report.matched[1] + report.matched[2];
    benchmark::DoNotOptimize(report);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["matched_per_scan"] = static_cast<double>(matched) / state.iterations();
}

void BM_ScanUpdate(benchmark::State& state) {
  const Corridor& world = corridor();
  FeatureEkfFilter filter(FeatureEkfConfig{}, world.map);
  size_t i = 0;
  double error_sum = 0.0;
  for (auto _ : state) {
    const size_t k = i++ % world.scans.size();
    reset_near_truth(filter, world.poses[k]);
    const ScanUpdateReport report = filter.update(world.scans[k]);
    benchmark::DoNotOptimize(report);
    error_sum += std::hypot(filter.pose().x() - world.poses[k].x, filter.pose().y() - world.poses[k].y);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["error_after_update_m"] = error_sum / state.iterations();
}

void BM_ScanAgreement(benchmark::State& state) {
  const Corridor& world = corridor();
  const ScanAgreement agreement(ScanAgreementConfig{}, world.map);
  size_t i = 0;
  double sum = 0.0;
  for (auto _ : state) {
    const size_t k = i++ % world.scans.size();
    sum += agreement.agreement(world.scans[k], world.poses[k]).value_or(0.0);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["agreement"] = sum / state.iterations();
}

// The agreement's 90 casts per scan: every wall tested per beam (Arg 0, the direct formula, what
// agreement() did before issue 25) or the walls culled by range and bearing (Arg 1, cast_all).
void BM_AgreementCasts(benchmark::State& state) {
  const Corridor& world = corridor();
  const ScanAgreement agreement(ScanAgreementConfig{}, world.map);
  const bool culled = state.range(0) == 1;
  size_t i = 0;
  double sum = 0.0;
  for (auto _ : state) {
    const size_t k = i++ % world.scans.size();
    const LaserScan& scan = world.scans[k];
    const Pose2 laser = world.poses[k] * Pose2::from_isometry(scan.sensor_pose);
    std::vector<double> headings;
    for (size_t b = 0; b < scan.ranges.size(); b += scan.ranges.size() / 90) headings.push_back(laser.theta + scan.angle(b));
    if (culled) {
      for (const double r : agreement.cast_all({laser.x, laser.y}, headings, scan.range_max)) sum += std::isfinite(r);
    } else {
      for (const double h : headings) sum += std::isfinite(agreement.cast({laser.x, laser.y}, h, scan.range_max));
    }
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["walls"] = static_cast<double>(world.map.lines.size());
  state.counters["hits_per_scan"] = sum / state.iterations();
}

// What the plugin runs per scan while tracking: the update, the agreement, the state.
void BM_MonitoredScanUpdate(benchmark::State& state) {
  const Corridor& world = corridor();
  RelocalizingFeatureEkf filter(FeatureEkfConfig{}, world.map);
  size_t i = 0, tracking = 0;
  for (auto _ : state) {
    const size_t k = i++ % world.scans.size();
    const Pose2& truth = world.poses[k];
    filter.set_pose({truth.x + 0.03, truth.y - 0.02, truth.theta + 0.01},
                    Eigen::Vector3d(0.05 * 0.05, 0.05 * 0.05, 0.02 * 0.02).asDiagonal());
    const ScanOutcome outcome = filter.update(world.scans[k]);
    tracking += outcome.localization.state == LocalizationState::kTracking;
    benchmark::DoNotOptimize(outcome);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["tracking_share"] = static_cast<double>(tracking) / state.iterations();
}

// One scan while lost: arg 1 = a generation (line pairs, cast, the best join), 0 = the tracked
// hypotheses of the previous generation corrected and cast again.
void BM_GlobalSearchScan(benchmark::State& state) {
  const Corridor& world = corridor();
  const FeatureEkfConfig config;
  const FeatureEkfFilter filter(config, world.map);
  const ScanAgreement agreement(config.agreement, filter.map());
  GlobalFeatureSearch search(config.global_search, filter, agreement);
  const bool generate = state.range(0) == 1;
  size_t i = 0, tracked = 0;
  for (auto _ : state) {
    const size_t k = i++ % world.scans.size();
    if (generate) {
      search.reset();
    } else {
      state.PauseTiming();
      search.reset();
      search.update(world.features[k], world.scans[k], true);
      state.ResumeTiming();
    }
    const GlobalSearchResult result = search.update(world.features[k], world.scans[k], generate);
    tracked += result.tracked.size();
    benchmark::DoNotOptimize(result);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["hypotheses"] = static_cast<double>(tracked) / state.iterations();
}

}  // namespace

BENCHMARK(BM_Extraction);
BENCHMARK(BM_AssociationAndUpdate);
BENCHMARK(BM_ScanUpdate);
BENCHMARK(BM_ScanAgreement);
BENCHMARK(BM_AgreementCasts)->Arg(0)->Arg(1);
BENCHMARK(BM_MonitoredScanUpdate);
BENCHMARK(BM_GlobalSearchScan)->Arg(1)->Arg(0);
BENCHMARK_MAIN();
