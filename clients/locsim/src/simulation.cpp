#include "locd/sim/simulation.hpp"

#include <algorithm>
#include <cmath>

#include "locd/sim/odometry_model.hpp"

namespace locd::sim {

namespace {
double truth_sample_period(const Params& sensors) {
  // Truth is sampled at the odometry rate (50 Hz when there is no odometry).
  if (sensors.has("odometry")) return 1.0 / OdometryConfig::from_params(sensors.child("odometry")).rate_hz;
  return 0.02;
}

// The random streams of the kidnap and the wrong start, apart from the sensors' (seed, index).
constexpr uint64_t kKidnapStream = 1'000'001, kWrongStartStream = 1'000'002;

std::mt19937_64 stream(uint64_t seed, uint64_t which) {
  std::seed_seq sequence{seed, which};
  return std::mt19937_64(sequence);
}

// The truth: with a kidnap, first the drive without it (to know where the robot is at at_s),
// then the same drive carried to the destination at at_s.
Trajectory truth_of(const Scenario& scenario, uint64_t seed, double duration_s, std::optional<Pose2>& destination) {
  const double period = truth_sample_period(scenario.sensors);
  Trajectory undisturbed = Trajectory::generate(scenario.robot, duration_s, period);
  if (!scenario.kidnap) return undisturbed;
  const KidnapSpec& k = *scenario.kidnap;
  if (k.to) {
    destination = *k.to;
  } else {
    const Pose2 there = undisturbed.at(k.at_s).pose;
    auto rng = stream(seed, kKidnapStream);
    destination = random_route_pose(scenario.robot, {there.x, there.y}, k.min_distance_m, rng, "kidnap.min_distance_m");
  }
  return Trajectory::generate(scenario.robot, duration_s, period, Teleport{k.at_s, *destination});
}
}  // namespace

Simulation::Simulation(const Scenario& scenario, uint64_t seed, double duration_s, int64_t stamp_origin_ns)
    : initial_stddev_(scenario.localizer.initial_stddev),
      duration_(duration_s),
      origin_ns_(stamp_origin_ns),
      world_(scenario.world ? scenario.world : std::make_shared<SegmentWorld>(SegmentWorld::from_feature_map(scenario.map))),
      truth_(truth_of(scenario, seed, duration_s, kidnap_destination_)) {
  const Pose2 start = truth_.at(0.0).pose;
  if (scenario.localizer.wrong_start_min_distance_m) {
    auto rng = stream(seed, kWrongStartStream);
    initial_pose_ = random_route_pose(scenario.robot, {start.x, start.y}, *scenario.localizer.wrong_start_min_distance_m,
                                      rng, "localizer.wrong_start.min_distance_m");
    event_ = SimulatedEvent{"wrong_start", 0.0, std::hypot(initial_pose_.x - start.x, initial_pose_.y - start.y)};
  } else {
    const Pose2& offset = scenario.localizer.initial_pose_offset;
    initial_pose_ = Pose2(start.x + offset.x, start.y + offset.y, normalize_angle(start.theta + offset.theta));
  }
  if (scenario.kidnap) {
    const double at = scenario.kidnap->at_s;
    const Pose2 before = truth_.at(std::max(at - truth_.sample_period(), 0.0)).pose;
    event_ = SimulatedEvent{"kidnap", at, std::hypot(kidnap_destination_->x - before.x, kidnap_destination_->y - before.y)};
  }
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
  const Pose2& given = initial_pose_;
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
