#include "locd/sim/simulation.hpp"

#include <cmath>

#include "locd/sim/odometry_model.hpp"

namespace locd::sim {

namespace {
double truth_sample_period(const Params& sensors) {
  // Truth is sampled at the odometry rate (50 Hz when there is no odometry).
  if (sensors.has("odometry")) return 1.0 / OdometryConfig::from_params(sensors.child("odometry")).rate_hz;
  return 0.02;
}
}  // namespace

Simulation::Simulation(const Scenario& scenario, uint64_t seed, double duration_s, int64_t stamp_origin_ns)
    : initial_pose_offset_(scenario.localizer.initial_pose_offset),
      initial_stddev_(scenario.localizer.initial_stddev),
      duration_(duration_s),
      origin_ns_(stamp_origin_ns),
      world_(scenario.world ? scenario.world : std::make_shared<SegmentWorld>(SegmentWorld::from_feature_map(scenario.map))),
      truth_(Trajectory::generate(scenario.robot, duration_s, truth_sample_period(scenario.sensors))) {
  sensors_ = make_sensor_models(scenario.sensors, world_);
  for (size_t i = 0; i < sensors_.size(); ++i) {
    std::seed_seq sequence{seed, static_cast<uint64_t>(i)};
    random_.emplace_back(sequence);
  }
  next_index_.assign(sensors_.size(), 0);
}

int64_t Simulation::stamp_of(double t) const { return origin_ns_ + static_cast<int64_t>(std::llround(t * 1e9)); }

double Simulation::time_of(int64_t stamp_ns) const { return static_cast<double>(stamp_ns - origin_ns_) * 1e-9; }

std::optional<SimulatedMeasurement> Simulation::next() {
  int chosen = -1;
  double chosen_t = 0.0;
  for (size_t i = 0; i < sensors_.size(); ++i) {
    const double t = static_cast<double>(next_index_[i]) / sensors_[i]->rate_hz();
    if (t > duration_ + 1e-9) continue;
    if (chosen < 0 || t < chosen_t - 1e-12) {
      chosen = static_cast<int>(i);
      chosen_t = t;
    }
  }
  if (chosen < 0) return std::nullopt;
  ++next_index_[chosen];
  SimulatedMeasurement m;
  m.t = chosen_t;
  m.sensor = sensors_[chosen]->name();
  m.measurement = sensors_[chosen]->measure(truth_.at(chosen_t), stamp_of(chosen_t), random_[chosen]);
  return m;
}

PoseEstimate Simulation::initial_pose() const {
  const Pose2 start = truth_.at(0.0).pose;
  const Pose2& offset = initial_pose_offset_;
  const Pose2 given(start.x + offset.x, start.y + offset.y, normalize_angle(start.theta + offset.theta));
  PoseEstimate p;
  p.header.stamp_ns = stamp_of(0.0);
  p.header.frame_id = "map";
  p.pose = given.to_isometry();
  p.covariance = Matrix6d::Zero();
  const Eigen::Vector3d& s = initial_stddev_;
  p.covariance(0, 0) = s.x() * s.x();
  p.covariance(1, 1) = s.y() * s.y();
  p.covariance(2, 2) = 1e-6;
  p.covariance(3, 3) = 1e-6;
  p.covariance(4, 4) = 1e-6;
  p.covariance(5, 5) = s.z() * s.z();
  return p;
}

}  // namespace locd::sim
