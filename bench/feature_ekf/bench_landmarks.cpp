// Speed of the landmark models (issue 3: >= 20,000 filter updates per second on one core).
// A 120 s stretch of the road_signs drive is recorded once (400 Hz IMU, 1 Hz detection frames);
// BM_ImuPrediction times eq. 7-9 + 14 per IMU sample; BM_DetectionUpdate/<strategy> times one
// frame's association and update (sec. 2.2, eq. 12-13) against the database of 225 signs, from
// the prior the drive had at that frame; BM_DriveReplay/<strategy> replays everything.
#include <benchmark/benchmark.h>

#include "locd/sim_feature_ekf/landmark_filter_run.hpp"

using namespace locd;
using namespace locd::feature_ekf;
namespace rs = locd::sim::road_signs;

namespace test = locd::sim::road_signs;

namespace {

struct Recording {
  rs::RoadSignWorld world{rs::WorldConfig{}};
  std::vector<Measurement> events;
  std::vector<Imu> imu;
  std::vector<LandmarkDetections> frames;
  rs::DriveTruth start;
  Recording() {
    rs::DriveConfig config;
    config.duration = 120.0;
    rs::RoadSignDrive drive(world, config, 5, 1);
    start = drive.truth();
    while (auto e = drive.next()) {
      events.push_back(e->measurement);
      if (const auto* i = std::get_if<Imu>(&e->measurement)) imu.push_back(*i);
      if (const auto* f = std::get_if<LandmarkDetections>(&e->measurement)) frames.push_back(*f);
    }
  }
};

const Recording& recording() {
  static const Recording r;
  return r;
}

LandmarkEkfFilter make_filter(AssociationStrategy s) {
  const Recording& r = recording();
  LandmarkEkfConfig c = test::config_for(r.world, s);
  c.initial_position = r.start.position;
  c.initial_velocity = r.start.velocity;
  return LandmarkEkfFilter(c, test::database_of(r.world));
}

void BM_ImuPrediction(benchmark::State& state) {
  const Recording& r = recording();
  LandmarkEkfFilter filter = make_filter(AssociationStrategy::kPda);
  size_t i = 0;
  int64_t offset = 0;
  for (auto _ : state) {
    Imu imu = r.imu[i];
    imu.header.stamp_ns += offset;
    filter.apply_imu(imu);
    if (++i == r.imu.size()) {
      i = 0;
      offset += r.imu.back().header.stamp_ns + 1'000'000'000;
    }
  }
  benchmark::DoNotOptimize(filter.state());
  state.SetItemsProcessed(state.iterations());
}

// Each frame from the state the drive reached just before it (snapshots taken once).
void BM_DetectionUpdate(benchmark::State& state) {
  const Recording& r = recording();
  const AssociationStrategy strategy = static_cast<AssociationStrategy>(state.range(0));
  LandmarkEkfFilter filter = make_filter(strategy);
  struct Snapshot {
    LandmarkEkfFilter::State x;
    LandmarkEkfFilter::StateMatrix P;
    const LandmarkDetections* frame;
  };
  std::vector<Snapshot> snapshots;
  for (const Measurement& m : r.events) {
    if (const auto* imu = std::get_if<Imu>(&m)) filter.apply_imu(*imu);
    if (const auto* f = std::get_if<LandmarkDetections>(&m)) {
      if (!f->detections.empty()) snapshots.push_back({filter.state(), filter.covariance(), f});
      filter.update(*f);
    }
  }
  const HorizontalModel& model = filter.model();
  const Eigen::Matrix4d J = model.enu_jacobian();
  size_t i = 0, detections = 0;
  for (auto _ : state) {
    const Snapshot& s = snapshots[i];
    filter.set_state_enu(model.position_enu(s.x), model.velocity_enu(s.x), J * s.P * J.transpose());
    benchmark::DoNotOptimize(filter.update(*s.frame));
    detections += s.frame->detections.size();
    i = (i + 1) % snapshots.size();
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["detections_per_frame"] = static_cast<double>(detections) / static_cast<double>(state.iterations());
  state.SetLabel(association_strategy_name(strategy));
}

void BM_DriveReplay(benchmark::State& state) {
  const Recording& r = recording();
  const AssociationStrategy strategy = static_cast<AssociationStrategy>(state.range(0));
  for (auto _ : state) {
    LandmarkEkfFilter filter = make_filter(strategy);
    for (const Measurement& m : r.events) {
      if (const auto* imu = std::get_if<Imu>(&m)) filter.apply_imu(*imu);
      if (const auto* f = std::get_if<LandmarkDetections>(&m)) filter.update(*f);
    }
    benchmark::DoNotOptimize(filter.state());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(r.events.size()));
  state.SetLabel(association_strategy_name(strategy));
}

}  // namespace

BENCHMARK(BM_ImuPrediction);
BENCHMARK(BM_DetectionUpdate)->DenseRange(0, 3);
BENCHMARK(BM_DriveReplay)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
