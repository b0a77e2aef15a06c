// A simulated sensor: a rate and a measurement of the truth at a stamp. Each model is its own
// class in its own file, configured from its entry under the scenario's `sensors`; adding a
// sensor is adding a model and one line in make_sensor_models.
#pragma once

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "locd/sdk/params.hpp"
#include "locd/sdk/types.hpp"
#include "locd/sim/trajectory.hpp"

namespace locd::sim {

class RangeWorld;

class SensorModel {
 public:
  virtual ~SensorModel() = default;
  virtual const std::string& name() const = 0;
  virtual double rate_hz() const = 0;
  // The measurement taken at `truth` (called in time order, once per period), stamped stamp_ns.
  virtual Measurement measure(const TruthSample& truth, int64_t stamp_ns, std::mt19937_64& rng) = 0;
};

// Every sensor under `sensors` (laser, odometry); unknown names are an error listing the known.
std::vector<std::unique_ptr<SensorModel>> make_sensor_models(const Params& sensors,
                                                             std::shared_ptr<const RangeWorld> world);

}  // namespace locd::sim
