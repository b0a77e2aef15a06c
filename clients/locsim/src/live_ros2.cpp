#include "live_ros2.hpp"

#include <cmath>
#include <stdexcept>
#include <thread>

#include "locd/sim/simulation.hpp"

namespace locd::sim {
namespace {

int64_t wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// The frame and mount of the scenario's laser, as its first simulated scan carries them.
std::string ros2_section(const Scenario& scenario, uint64_t seed, const std::string& ros_namespace) {
  Simulation probe(scenario, seed, scenario.duration_s);
  while (auto m = probe.next()) {
    if (const auto* scan = std::get_if<LaserScan>(&m->measurement)) {
      return Ros2Robot::config_section(ros_namespace, scan->header.frame_id, scan->sensor_pose);
    }
  }
  throw std::invalid_argument("locsim live --ros2: the scenario has no laser; the ROS 2 robot sends scans and odometry");
}

}  // namespace

LiveRos2Robot::LiveRos2Robot(const Scenario& scenario, uint64_t seed, const LiveOptions& options,
                             std::function<void(const PoseUpdate&)> on_pose)
    : section_(ros2_section(scenario, seed, options.ros2_namespace)),
      participant_(options.domain_id),
      robot_(participant_, Ros2RobotOptions{options.ros2_namespace},
             [robot_id = scenario.robot.id, plugin = scenario.localizer.plugin,
              on_pose = std::move(on_pose)](const PoseEstimate& pose) {
               // PoseWithCovarianceStamped carries no plugin update time.
               on_pose(PoseUpdate{robot_id, plugin, pose, std::nan(""), wall_ns()});
             }) {}

bool LiveRos2Robot::wait_matched(std::chrono::milliseconds timeout) const {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!robot_.matched()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

bool LiveRos2Robot::publish(const Measurement& measurement) {
  if (!std::holds_alternative<LaserScan>(measurement) && !std::holds_alternative<Odometry>(measurement)) return false;
  robot_.publish(measurement);
  return true;
}

}  // namespace locd::sim
