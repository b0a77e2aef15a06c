// A running scenario: the truth trajectory and every sensor's measurements, merged in stamp
// order. Each sensor draws from its own random stream (seed, sensor index), so adding a sensor
// leaves the others' noise unchanged.
#pragma once

#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "locd/sim/scenario.hpp"
#include "locd/sim/sensor_model.hpp"
#include "locd/sim/trajectory.hpp"
#include "locd/sim/world.hpp"

namespace locd::sim {

// A kidnap, or a wrong start (at t = 0), and how far it put the estimate off (m).
struct SimulatedEvent {
  std::string kind;  // "kidnap", "wrong_start"
  double t = 0.0;
  double distance_m = 0.0;
};

struct SimulatedMeasurement {
  double t = 0.0;  // s since the start
  std::string sensor;
  Measurement measurement;
};

class Simulation {
 public:
  // stamp_origin_ns: the stamp of t = 0.
  Simulation(const Scenario& scenario, uint64_t seed, double duration_s, int64_t stamp_origin_ns = 1'000'000'000);

  // The next measurement in time order (ties: sensors in declaration order), nullopt at the end.
  std::optional<SimulatedMeasurement> next();

  const Trajectory& truth() const { return truth_; }
  std::shared_ptr<const RangeWorld> world() const { return world_; }
  double duration() const { return duration_; }
  int64_t stamp_of(double t) const;
  double time_of(int64_t stamp_ns) const;
  // The pose the localizer is given at the start: truth + initial_pose_offset, or the wrong start
  // drawn from the seed, with covariance diag(initial_stddev^2) over (x, y, yaw).
  PoseEstimate initial_pose() const;
  // The event that makes the estimate wrong on purpose, if the scenario has one.
  std::optional<SimulatedEvent> event() const { return event_; }

 private:
  Pose2 initial_pose_;
  Eigen::Vector3d initial_stddev_;
  double duration_;
  int64_t origin_ns_;
  std::shared_ptr<const RangeWorld> world_;
  std::optional<Pose2> kidnap_destination_;  // before truth_: set while truth_ is made
  Trajectory truth_;
  std::vector<std::unique_ptr<SensorModel>> sensors_;
  std::vector<std::mt19937_64> random_;
  std::vector<uint64_t> next_index_;
  std::optional<SimulatedEvent> event_;
};

}  // namespace locd::sim
