#include "locd/sim/sensor_model.hpp"

#include "locd/sim/laser_scanner.hpp"
#include "locd/sim/odometry_model.hpp"
#include "locd/sim/ceiling_camera_sensor.hpp"

namespace locd::sim {

std::vector<std::unique_ptr<SensorModel>> make_sensor_models(const Params& sensors,
                                                             std::shared_ptr<const RangeWorld> world) {
  sensors.expect_only({"odometry", "laser", "ceiling_camera"});
  std::vector<std::unique_ptr<SensorModel>> models;
  // Odometry first: at equal stamps a plugin predicts before it corrects.
  if (sensors.has("odometry")) {
    models.push_back(std::make_unique<OdometryModel>(OdometryConfig::from_params(sensors.child("odometry"))));
  }
  if (sensors.has("laser")) {
    models.push_back(std::make_unique<LaserScannerModel>(LaserScannerConfig::from_params(sensors.child("laser")), world));
  }
  if (sensors.has("ceiling_camera")) {
    models.push_back(make_ceiling_camera_sensor(sensors.child("ceiling_camera")));
  }
  if (models.empty()) throw ConfigError("parameter 'sensors' names no sensor; known: odometry, laser, ceiling_camera");
  return models;
}

}  // namespace locd::sim
