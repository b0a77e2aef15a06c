// The `ros2:` section of a robot's config (next to `plugin:` and `params:`, plugin_config.hpp):
// which ROS 2 topics locd reads and writes for the robot, so a ROS 2 robot needs no bridge node.
//
//   ros2:
//     namespace: /robot1          # the robot's ROS 2 namespace ("" or "/" = none)
//     topics:                     # only the topics listed are used; a name without a leading '/'
//       scan: scan                #   is resolved in the namespace (/robot1/scan), one with it
//       odometry: odom            #   is used as it is (/tf)
//       initial_pose: initialpose
//       pose: amcl_pose
//       tf: /tf
//     map_frame: map              # frame of the pose, the grids and the map cloud
//     base_frame: base_link       # a sensor message in this frame is at the robot's origin
//     sensor_frames:              # every other sensor frame: its pose in base_frame,
//       laser: [0.2, 0, 0.3, 0, 0, 0]   # x y z (m) roll pitch yaw (rad)
//
// The keys of `topics` and what each carries are in kRos2Topics below; README "ROS 2 robots"
// documents them. Every error is a ConfigError naming the key, where it stands and what is
// allowed. No DDS in here: the server's ROS 2 bridge turns this into endpoints.
#pragma once

#include <Eigen/Geometry>
#include <map>
#include <string>

#include "locd/sdk/params.hpp"

namespace locd {

struct Ros2TopicKind {
  const char* key;       // the key under ros2.topics
  const char* ros_type;  // the ROS 2 type, e.g. "sensor_msgs/msg/LaserScan"
  bool input;            // read by locd (true) or written by locd
  const char* carries;   // for messages and the README
};

inline constexpr Ros2TopicKind kRos2Topics[] = {
    {"scan", "sensor_msgs/msg/LaserScan", true, "2D laser scans"},
    {"cloud", "sensor_msgs/msg/PointCloud2", true, "3D point clouds (x, y, z, optional intensity)"},
    {"image", "sensor_msgs/msg/Image", true, "camera images (mono8, bgr8, rgb8)"},
    {"imu", "sensor_msgs/msg/Imu", true, "attitude, angular velocity, acceleration"},
    {"odometry", "nav_msgs/msg/Odometry", true, "wheel odometry: base frame in the odometry frame"},
    {"initial_pose", "geometry_msgs/msg/PoseWithCovarianceStamped", true,
     "initial pose in map_frame (RViz's 2D Pose Estimate)"},
    {"pose", "geometry_msgs/msg/PoseWithCovarianceStamped", false, "the pose in map_frame, transient-local"},
    {"tf", "tf2_msgs/msg/TFMessage", false, "map_frame -> odometry frame, one transform per pose"},
    {"grid", "nav_msgs/msg/OccupancyGrid", false, "grids, one topic per layer: <name>/<layer>"},
    {"map_cloud", "sensor_msgs/msg/PointCloud2", false, "the point-cloud map, transient-local"},
    {"particles", "geometry_msgs/msg/PoseArray", false, "the plugin's particles"},
};

struct Ros2Config {
  std::string ros_namespace;                  // "/robot1", or "" for the root namespace
  std::map<std::string, std::string> topics;  // key of kRos2Topics -> fully qualified name ("/robot1/scan")
  std::string map_frame = "map";
  std::string base_frame = "base_link";
  std::map<std::string, Eigen::Isometry3d> sensor_frames;  // frame -> its pose in base_frame

  // The fully qualified ROS 2 name for `key`, or "" when the robot does not use that topic.
  std::string topic(const std::string& key) const;
};

// Parses the `ros2` section (`section` rooted at "ros2"). Throws ConfigError.
Ros2Config parse_ros2_config(const Params& section);

// "rt/robot1/scan" for "/robot1/scan": the DDS topic ROS 2 uses for a topic name.
std::string ros2_dds_topic(const std::string& ros_name);

}  // namespace locd
