// The fleet as Foxglove channels: DDS readers in every robot's partition (robot.*, or the robots
// asked for) turn locd's samples into Foxglove messages on per-robot channels, advertised when a
// robot is first seen:
//   /<robot>/pose               foxglove.PoseInFrame      pose in map
//   /<robot>/pose_covariance    foxglove.SceneUpdate      xy covariance as a 2-sigma ellipse
//   /<robot>/transforms         foxglove.FrameTransform   map -> <robot>/base_link at each pose
//   /<robot>/particles          foxglove.PosesInFrame     particle filters' particles
//   /<robot>/diagnostics        locd.DiagnosticValues     the plugin's named values
//   /<robot>/scan               foxglove.PointCloud       the scan's returns in <robot>/base_link
//   /<robot>/cloud              foxglove.PointCloud       the 3D cloud in <robot>/base_link
//   /<robot>/landmark_map       foxglove.SceneUpdate      landmark / feature map (lines, points)   latched
//   /<robot>/grid/<layer>       foxglove.Grid             belief, elevation, occupancy grids       latched
//   /<robot>/map_cloud          foxglove.PointCloud       registered point-cloud map               latched
//   /<robot>/exploration_goal   foxglove.PoseInFrame      next best scan pose                      latched
//   /<robot>/status             locd.SessionStatus        state, counters, localization, errors    latched
//   /<robot>/ground_truth       foxglove.PoseInFrame      simulated truth (locsim)
// A sample is converted only when a client subscribes to its channel (latched channels always,
// so a late subscriber gets the current map). DDS listener threads convert and hand the text to
// the server's thread; they never wait on a client.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ws_server.hpp"

namespace locd::view {

struct ViewOptions {
  uint32_t domain_id = 0;
  std::vector<std::string> robots;  // empty: every robot
  size_t max_robots = 1000;         // robots given channels; later ones are left out (and logged)
};

class FleetView {
 public:
  FleetView(FoxgloveServer& server, const ViewOptions& options);
  ~FleetView();
  FleetView(const FleetView&) = delete;
  FleetView& operator=(const FleetView&) = delete;

  size_t robots() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace locd::view
