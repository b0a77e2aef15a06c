// Conversions between ROS 2 messages (idl/ros2.idl) and the sdk types plugins see.
//
// Reading (a ROS 2 robot -> locd): every network-given size is checked against Limits before
// anything is allocated, then the sdk type's one check (validate.hpp) runs. Each failure is an
// InputError naming the field and what is allowed. A ROS 2 message carries no sensor pose: the
// pose of its frame in the robot's base frame comes from the robot's config (Ros2Config).
//
// Writing: locd's outputs as ROS 2 messages (pose, tf, grids, map clouds, particles), and, for
// programs that play a ROS 2 robot (locsim live --ros2, tests), sensors as a ROS 2 driver sends them.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "locd/dds/ros2.hpp"
#include "locd/sdk/plugin.hpp"
#include "locd/sdk/ros2_config.hpp"
#include "locd/sdk/types.hpp"

namespace locd::dds::ros2 {

// builtin_interfaces/Time <-> nanoseconds. stamp_ns refuses a zero stamp (an unstamped message:
// its time is unknown) and nanosec >= 1e9.
int64_t stamp_ns(const Time& t);
Time to_time(int64_t stamp_ns);

// What a ROS 2 robot's config says about frames (Ros2Config): the base frame and each sensor
// frame's pose in it.
struct Frames {
  std::string map_frame = "map";
  std::string base_frame = "base_link";
  std::map<std::string, Eigen::Isometry3d> sensor_frames;

  static Frames from(const Ros2Config& config);
  // The pose of `frame` in the base frame; InputError naming the frame when the config lacks it.
  Eigen::Isometry3d sensor_pose(const std::string& frame) const;
};

locd::LaserScan from_ros2(const ros2::LaserScan& m, const Frames& frames, const Limits& limits);
// x, y, z as FLOAT32 or FLOAT64, an optional `intensity` of any datatype, either byte order,
// rows padded (row_step > width * point_step), invalid (NaN) points skipped.
locd::PointCloud from_ros2(const PointCloud2& m, const Frames& frames, const Limits& limits);
// mono8, bgr8, rgb8, bgra8, rgba8 (colour images become bgr8).
locd::Image from_ros2(const ros2::Image& m, const Limits& limits);
// An attitude IMU: orientation required (orientation_covariance[0] != -1). Rotated into the base
// frame; gravity (9.80665 m/s^2 along the level frame's z) is taken out of the acceleration.
locd::Imu from_ros2(const ros2::Imu& m, const Frames& frames);
// Pose of child_frame_id (the base frame) in header.frame_id, twist in child_frame_id.
locd::Odometry from_ros2(const ros2::Odometry& m);
// An initial pose; its frame must be the map frame.
locd::PoseEstimate from_ros2(const PoseWithCovarianceStamped& m, const Frames& frames);

// The frame ids a message names (for the tf output and messages).
std::string frame_id(const Header& h);
std::string child_frame_id(const ros2::Odometry& m);

// ------------------------------------------------------------------------ writing
void write(const Writer<PoseWithCovarianceStamped>& w, const locd::PoseEstimate& pose, const std::string& frame_id);
// One TransformStamped: `parent` -> `child` at `stamp_ns`.
void write(const Writer<TFMessage>& w, int64_t stamp_ns, const std::string& parent, const std::string& child,
           const Eigen::Isometry3d& parent_from_child);
// A grid layer as 0..100 with -1 for NaN: values already in [0, 1] (occupancy probabilities) are
// scaled by 100; any other layer (belief, elevation) is scaled from its [min, max] to [0, 100].
void write(const Writer<OccupancyGrid>& w, int64_t stamp_ns, const locd::GridLayer& grid, const std::string& frame_id);
// x, y, z FLOAT32 (and intensity FLOAT32 when present), little-endian, one row.
void write(const Writer<PointCloud2>& w, int64_t stamp_ns, const locd::PointCloud& cloud, const std::string& frame_id);
void write(const Writer<PoseArray>& w, int64_t stamp_ns, const std::vector<locd::Particle2D>& particles,
           const std::string& frame_id);
// A robot's sensors as its ROS 2 drivers publish them (the scan's sensor_pose stays behind: the
// receiver knows it from the frame).
void write(const Writer<ros2::LaserScan>& w, const locd::LaserScan& scan);
void write(const Writer<ros2::Odometry>& w, const locd::Odometry& odometry, const std::string& child_frame_id);

}  // namespace locd::dds::ros2
