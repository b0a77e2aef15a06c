// The `ros2:` section of a robot's config (next to `plugin:` and `params:`, plugin_config.hpp):
// which ROS 2 topics locd reads and writes for the robot, so a ROS 2 robot needs no bridge node,
// and how locd behaves there, as Nav2 AMCL does (ros-navigation/navigation2,
// nav2_amcl/src/amcl_node.cpp; README "ROS 2 robots" says what matches and what does not).
//
//   ros2:
//     namespace: /robot1          # the robot's ROS 2 namespace ("" or "/" = none)
//     topics:                     # only the topics listed are used; a name without a leading '/'
//       scan: scan                #   is resolved in the namespace (/robot1/scan), one with it
//       odometry: odom            #   is used as it is (/tf). Without `topics`: AMCL's set,
//       initial_pose: /initialpose  #   kAmclTopics below
//       pose: amcl_pose
//       tf: /tf
//     map_frame: map              # frame of the pose, the grids and the map cloud (AMCL global_frame_id)
//     base_frame: base_link       # a sensor message in this frame is at the robot's origin
//     odom_frame: odom            # the odometry's frame; map_frame -> odom_frame goes on tf
//     sensor_frames:              # every other sensor frame: its pose in base_frame; without
//       laser: [0.2, 0, 0.3, 0, 0, 0]   # it, frames come from tf_static and tf at each stamp
//     transform_tolerance: 1.0    # s: map -> odom is stamped this much after the pose (AMCL's)
//     tf_broadcast: true          # write map -> odom (AMCL's); false: pose only
//     odometry_timeout: 1.0       # s: map -> odom waits this long for odometry at the pose's stamp
//     particles_type: nav2_msgs/msg/ParticleCloud   # or geometry_msgs/msg/PoseArray
//
// A Nav2 params file (`amcl: {ros__parameters: ...}`) is a robot config too: parse_nav2_amcl
// below reads AMCL's ROS keys into this section. The keys of `topics` and what each carries
// are in kRos2Topics; every error is a ConfigError naming the key, where it stands and what is
// allowed. No DDS in here: the server's ROS 2 bridge turns this into endpoints.
#pragma once

#include <Eigen/Geometry>
#include <map>
#include <string>
#include <utility>

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
    {"tf_static", "tf2_msgs/msg/TFMessage", true, "static transforms: sensor frames when sensor_frames is not given"},
    {"tf", "tf2_msgs/msg/TFMessage", false, "map_frame -> odom_frame, one transform per pose (sensor frames read too)"},
    {"map", "nav_msgs/msg/OccupancyGrid", false, "the occupancy map as map_server publishes it, transient-local"},
    {"grid", "nav_msgs/msg/OccupancyGrid", false, "grids, one topic per layer: <name>/<layer>"},
    {"map_cloud", "sensor_msgs/msg/PointCloud2", false, "the point-cloud map, transient-local"},
    {"particles", "nav2_msgs/msg/ParticleCloud", false, "the plugin's particles (or geometry_msgs/msg/PoseArray)"},
};

// The topics without `ros2.topics`: Nav2 AMCL's (amcl_node.cpp: "scan", "initialpose" as RViz
// publishes it, /initialpose in the root namespace, "amcl_pose", "particle_cloud", tf2's /tf and
// /tf_static), and nav_msgs/Odometry on "odom" (AMCL reads odometry from tf).
inline constexpr std::pair<const char*, const char*> kAmclTopics[] = {
    {"scan", "scan"},         {"odometry", "odom"}, {"initial_pose", "/initialpose"}, {"pose", "amcl_pose"},
    {"tf", "/tf"},            {"tf_static", "/tf_static"}, {"particles", "particle_cloud"},
};

enum class ParticlesType { kParticleCloud, kPoseArray };

struct Ros2Config {
  std::string ros_namespace;                  // "/robot1", or "" for the root namespace
  std::map<std::string, std::string> topics;  // key of kRos2Topics -> fully qualified name ("/robot1/scan")
  std::string map_frame = "map";
  std::string base_frame = "base_link";
  std::string odom_frame = "odom";
  std::map<std::string, Eigen::Isometry3d> sensor_frames;  // frame -> its pose in base_frame
  double transform_tolerance_s = 1.0;  // AMCL transform_tolerance: map -> odom stamped pose stamp + this
  bool tf_broadcast = true;            // AMCL tf_broadcast
  double odometry_timeout_s = 1.0;     // map -> odom waits at most this for odometry at the pose's stamp
  ParticlesType particles_type = ParticlesType::kParticleCloud;

  // The fully qualified ROS 2 name for `key`, or "" when the robot does not use that topic.
  std::string topic(const std::string& key) const;
  // The ROS 2 type of the topic of `key` ("sensor_msgs/msg/LaserScan").
  const char* ros_type(const std::string& key) const;
  // Sensor frames come from tf: sensor_frames is empty. Then tf_static (topics.tf_static or
  // /tf_static) and tf (topics.tf or /tf) are read.
  bool frames_from_tf() const { return sensor_frames.empty(); }
  std::string tf_static_topic() const;
  std::string tf_input_topic() const;
};

// Parses the `ros2` section (`section` rooted at "ros2"). Throws ConfigError.
Ros2Config parse_ros2_config(const Params& section);

// A Nav2 params file's `amcl.ros__parameters` (`amcl`), with an optional `ros2` section beside it
// (`section`, may be absent): the ROS keys AMCL takes (base_frame_id, global_frame_id,
// odom_frame_id, scan_topic, tf_broadcast, transform_tolerance, ...) become this section's, as
// AMCL's defaults when absent (base_frame_id base_footprint); a key given in both places is
// refused. Removes those keys from `amcl`, so the plugin sees its own only. kAmclRosKeys lists
// them; README "A Nav2 params file" says what each does in locd.
Ros2Config parse_nav2_amcl(const Params& amcl, const Params* section);
extern const char* const kAmclRosKeys[11];

// "rt/robot1/scan" for "/robot1/scan": the DDS topic ROS 2 uses for a topic name.
std::string ros2_dds_topic(const std::string& ros_name);

}  // namespace locd
