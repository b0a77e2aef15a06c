// The scenario's hall (config/scenarios/ceiling_hall.yaml) and its camera, as the benchmarks
// use them: the simulator's world and renderer, and the plugin's camera, detector and filter
// parts configured to match (config/plugins/ceiling_pf.yaml defaults).
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "locd/ceiling_pf/ceiling_camera.hpp"
#include "locd/ceiling_pf/ceiling_detector.hpp"
#include "locd/ceiling_pf/ceiling_particle_filter.hpp"
#include "locd/sim_ceiling_pf/hall_drive.hpp"

namespace locd::bench {

struct Hall {
  sim::ceiling::CeilingCameraConfig camera_config;
  std::unique_ptr<sim::ceiling::CeilingWorld> world;
  std::unique_ptr<sim::ceiling::CeilingCameraRenderer> renderer;
  std::unique_ptr<ceiling_pf::CeilingCamera> camera;
  std::shared_ptr<ceiling_pf::NearestLandmarkIndex> index;

  Hall() {
    const Params scenario = Params::load_file(std::string(LOCD_SOURCE_DIR) + "/config/scenarios/ceiling_hall.yaml");
    const Params cam = scenario.child("sensors").child("ceiling_camera");
    camera_config = sim::ceiling::CeilingCameraConfig::from_params(cam);
    world = std::make_unique<sim::ceiling::CeilingWorld>(sim::ceiling::CeilingWorldConfig::from_params(cam.child("world")));
    renderer = std::make_unique<sim::ceiling::CeilingCameraRenderer>(camera_config, *world);
    const auto& c = camera_config;
    camera = std::make_unique<ceiling_pf::CeilingCamera>(
        ceiling_pf::CameraIntrinsics{c.width, c.height, c.fx, c.fy, c.cx, c.cy},
        ceiling_pf::CameraMounting{c.mount.x, c.mount.y, c.mount.theta, c.lens_height},
        world->config().ceiling_height);
    index = std::make_shared<ceiling_pf::NearestLandmarkIndex>(world->landmarks(), 3, 0.5,
                                                                camera->max_view_range() + 2.5, 50'000'000);
  }

  ceiling_pf::ParticleFilterConfig filter_config() const {
    ceiling_pf::ParticleFilterConfig f;
    f.max_range = camera->max_view_range() + 0.5;  // as the plugin sets it
    return f;
  }
};

}  // namespace locd::bench
