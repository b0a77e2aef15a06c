// locsim's `ceiling_camera` sensor: the rendered upward camera of ceiling_pf's hall
// (locd/sim_ceiling_pf/ceiling_world.hpp) as a SensorModel. Its scenario entry holds the camera
// and, under `world`, the hall (CeilingCameraConfig and CeilingWorldConfig::from_params).
#pragma once

#include <memory>

#include "locd/sim/sensor_model.hpp"

namespace locd::sim {

std::unique_ptr<SensorModel> make_ceiling_camera_sensor(const Params& params);

}  // namespace locd::sim
