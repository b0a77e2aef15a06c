// locsim's `ceiling_camera` sensor: the rendered upward camera of the ceiling hall as a
// locd::sim::SensorModel. Its scenario entry holds the camera and, under `world`, the hall
// (CeilingCameraConfig and CeilingWorldConfig::from_params).
#pragma once

#include <memory>

#include "locd/sdk/params.hpp"

namespace locd::sim {
class SensorModel;
}

namespace locd::sim::ceiling {

std::unique_ptr<SensorModel> make_ceiling_camera_sensor(const Params& params);

}  // namespace locd::sim::ceiling
