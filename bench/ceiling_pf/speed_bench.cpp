// Speed on one core (OpenCV limited to one thread):
//   BM_FilterUpdate/particles/scan   one camera frame: two odometry predictions and a correction
//                                    (Table 1 association, eq. 7-9, resampling when due) on the
//                                    paper's route; scan=1 is the baseline that finds the N nearest
//                                    landmarks by scanning the whole map (Table 1 as written).
//   BM_ImagePipeline/levels/refine   blur, threshold, Hough and eq. 1-3 on a rendered 640 x 480
//                                    frame; levels=0, refine=0 is the paper's pipeline at full
//                                    resolution (the baseline).
// Run: build/bench/ceiling_pf_speed_bench
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>

#include "hall_setup.hpp"

using namespace locd;
using namespace locd::ceiling_pf;

namespace {

struct RouteFrames {
  std::vector<std::vector<VelocityCommand>> odometry;  // per camera frame: the predictions before it
  std::vector<std::vector<Detection>> detections;
  std::vector<Pose2> truth;
  std::vector<cv::Mat> images;
};

const bench::Hall& hall() {
  static const bench::Hall h;
  return h;
}

// The first `seconds` of the paper's route: odometry commands and the detector's output per frame.
const RouteFrames& route_frames() {
  static const RouteFrames frames = [] {
    RouteFrames f;
    sim::ceiling::HallDrive drive(sim::ceiling::DriveConfig{}, *hall().renderer, 1);
    CeilingDetector detector{DetectorConfig{}};
    std::optional<Pose2> last;
    int64_t last_stamp = 0;
    std::vector<VelocityCommand> pending;
    while (auto e = drive.next(120.0)) {
      if (const auto* o = std::get_if<Odometry>(&e->measurement)) {
        const Pose2 p = Pose2::from_isometry(o->pose);
        if (last) pending.push_back(velocity_between(*last, p, 1e-9 * (o->header.stamp_ns - last_stamp)));
        last = p;
        last_stamp = o->header.stamp_ns;
      } else if (const auto* img = std::get_if<Image>(&e->measurement)) {
        const cv::Mat mono(img->height, img->width, CV_8UC1, const_cast<uint8_t*>(img->data.data()));
        std::vector<Detection> z;
        for (const auto& p : detector.detect_points(mono, *hall().camera)) z.push_back(Detection::from_point(p));
        f.odometry.push_back(pending);
        f.detections.push_back(z);
        f.truth.push_back(e->truth);
        if (f.images.size() < 50) f.images.push_back(mono.clone());
        pending.clear();
      }
    }
    return f;
  }();
  return frames;
}

void BM_FilterUpdate(benchmark::State& state) {
  const RouteFrames& frames = route_frames();
  ParticleFilterConfig config = hall().filter_config();
  config.kld_sampling = false;
  config.particles = static_cast<size_t>(state.range(0));
  config.scan_all_landmarks = state.range(1) != 0;
  CeilingParticleFilter filter(config, hall().index, VelocityMotionModel());
  const Eigen::Matrix3d start_cov = Eigen::Vector3d(0.05, 0.05, 0.02).cwiseAbs2().asDiagonal();
  size_t i = 0, detections = 0, updates = 0;
  filter.set_pose(frames.truth[0], start_cov);
  for (auto _ : state) {
    if (i == frames.detections.size()) {
      state.PauseTiming();
      i = 0;
      filter.set_pose(frames.truth[0], start_cov);
      state.ResumeTiming();
    }
    for (const VelocityCommand& u : frames.odometry[i]) filter.predict(u);
    const CorrectionReport r = filter.correct(frames.detections[i]);
    benchmark::DoNotOptimize(r);
    detections += frames.detections[i].size();
    ++updates;
    ++i;
  }
  state.counters["detections_per_frame"] = static_cast<double>(detections) / static_cast<double>(updates);
  state.counters["particles"] = static_cast<double>(filter.particles().size());
}
BENCHMARK(BM_FilterUpdate)
    ->ArgNames({"particles", "scan"})
    ->Args({200, 0})
    ->Args({200, 1})
    ->Args({5000, 0})
    ->Args({5000, 1})
    ->Unit(benchmark::kMillisecond);

void BM_ImagePipeline(benchmark::State& state) {
  const RouteFrames& frames = route_frames();
  DetectorConfig config;
  config.pyramid_levels = static_cast<int>(state.range(0));
  config.refine_centroid = state.range(1) != 0;
  if (config.pyramid_levels == 0) {  // full resolution: coarser accumulator, higher vote (tuned for recall)
    config.hough_dp = 2.0;
    config.accumulator_threshold = 20;
  }
  CeilingDetector detector(config);
  size_t i = 0, circles = 0, frames_done = 0;
  for (auto _ : state) {
    const auto points = detector.detect_points(frames.images[i], *hall().camera);
    benchmark::DoNotOptimize(points.data());
    circles += points.size();
    ++frames_done;
    i = (i + 1) % frames.images.size();
  }
  state.counters["circles_per_frame"] = static_cast<double>(circles) / static_cast<double>(frames_done);
}
BENCHMARK(BM_ImagePipeline)->ArgNames({"levels", "refine"})->Args({1, 1})->Args({0, 0})->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
