// `locsim live --ros2 NAMESPACE`: the simulated robot as a ROS 2 robot. Its odometry and scans go
// out as nav_msgs/Odometry and sensor_msgs/LaserScan (best effort, as ROS 2 drivers send them)
// in the namespace, its poses come back as geometry_msgs/PoseWithCovarianceStamped on amcl_pose,
// and the session config carries the `ros2:` section that asks locd for those topics. Session
// request, initial pose and truth stay on locd's own topics, so both paths are scored alike.
#pragma once

#include <chrono>
#include <functional>
#include <string>

#include "live.hpp"
#include "locd/dds/dds.hpp"
#include "locd/sim/ros2_robot.hpp"

namespace locd::sim {

class LiveRos2Robot {
 public:
  LiveRos2Robot(const Scenario& scenario, uint64_t seed, const LiveOptions& options,
                std::function<void(const PoseUpdate&)> on_pose);

  // The `ros2:` section to append to the session config (the laser frame and mount taken from
  // the scenario's first simulated scan).
  const std::string& config_section() const { return section_; }
  // Until locd's endpoints for the robot match (they appear when the session starts).
  bool wait_matched(std::chrono::milliseconds timeout) const;
  // Publishes odometry and scans on ROS 2; false for any other kind (it then goes the native way).
  bool publish(const Measurement& measurement);

 private:
  std::string section_;
  dds::Participant participant_;
  Ros2Robot robot_;
};

}  // namespace locd::sim
