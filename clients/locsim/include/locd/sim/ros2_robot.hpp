// A robot that speaks ROS 2 only, on plain Cyclone DDS: what its drivers publish (LaserScan and
// Odometry, best effort as rclcpp's SensorDataQoS, or reliable), RViz's initial pose, and readers
// of the pose locd writes for it (PoseWithCovarianceStamped) and of /tf. For `locsim live --ros2`
// and the tests: it is how a ROS 2 robot looks to locd, with no locd code on board.
#pragma once

#include <functional>
#include <string>

#include "locd/dds/ros2.hpp"
#include "locd/sdk/types.hpp"

namespace locd::sim {

struct Ros2RobotOptions {
  std::string ros_namespace;       // "/robot1"; topics scan, odom, initialpose, amcl_pose inside it; tf is /tf
  std::string base_frame = "base_link";
  dds::QosProfile sensor_qos = dds::QosProfile::kRos2SensorData;  // or kRos2Default: a reliable driver
};

class Ros2Robot {
 public:
  using PoseCallback = std::function<void(const PoseEstimate&)>;  // on a listener thread
  using TransformCallback = std::function<void(int64_t stamp_ns, const std::string& parent, const std::string& child,
                                               const Eigen::Isometry3d& parent_from_child)>;
  Ros2Robot(const dds::Participant& participant, Ros2RobotOptions options, PoseCallback on_pose,
            TransformCallback on_transform = nullptr);

  // The `ros2:` section of the robot's config that makes locd serve these topics, the laser
  // frame placed at `laser_pose` in the base frame.
  static std::string config_section(const std::string& ros_namespace, const std::string& laser_frame,
                                    const Eigen::Isometry3d& laser_pose);

  // Odometry (child frame = base frame) and LaserScan; other kinds throw std::invalid_argument.
  void publish(const Measurement& measurement);
  void publish_initial_pose(const PoseEstimate& pose);  // frame "map"
  // Whether locd's endpoints for the robot match the robot's: scan, odometry, initial pose, pose.
  bool matched() const;

 private:
  Ros2RobotOptions options_;
  dds::Writer<dds::ros2::LaserScan> scan_;
  dds::Writer<dds::ros2::Odometry> odometry_;
  dds::Writer<dds::ros2::PoseWithCovarianceStamped> initial_pose_;
  dds::Reader<dds::ros2::PoseWithCovarianceStamped> pose_;
  dds::Reader<dds::ros2::TFMessage> tf_;
};

}  // namespace locd::sim
