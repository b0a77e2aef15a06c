// Conversions between ROS 2 messages (idl/ros2.idl) and the sdk types plugins see.
//
// Reading (a ROS 2 robot -> locd): every network-given size is checked against Limits before
// anything is allocated, then the sdk type's one check (validate.hpp) runs. Each failure is an
// InputError naming the field and what is allowed. A ROS 2 message carries no sensor pose: the
// pose of its frame in the robot's base frame comes from the robot's config (Ros2Config) or, when
// that lists no sensor frame, from the robot's /tf_static and /tf at the message's stamp (Frames).
//
// Writing: locd's outputs as ROS 2 messages (pose, tf, grids, map clouds, particles), and, for
// programs that play a ROS 2 robot (locsim live --ros2, tests), sensors as a ROS 2 driver sends them.
#pragma once

#include <array>
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

// Where a sensor frame's pose comes from when the robot's config lists none: the transforms the
// robot publishes on /tf_static and /tf (the server's TransformBuffer).
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // The pose of `frame` in `target` at `stamp_ns`, as tf2's lookupTransform(target, frame, stamp)
  // gives it; InputError naming the frames and what is missing.
  virtual Eigen::Isometry3d pose_in(const std::string& target, const std::string& frame, int64_t stamp_ns) const = 0;
};

// What a ROS 2 robot's config says about frames (Ros2Config): the base frame and each sensor
// frame's pose in it, or, when it lists none, where to look them up.
struct Frames {
  std::string map_frame = "map";
  std::string base_frame = "base_link";
  std::map<std::string, Eigen::Isometry3d> sensor_frames;
  const FrameSource* tf = nullptr;  // used when sensor_frames is empty

  static Frames from(const Ros2Config& config, const FrameSource* tf = nullptr);
  // The pose of `frame` (a leading '/' dropped) in the base frame at `stamp_ns`; InputError
  // naming the frame when neither the config nor tf gives it.
  Eigen::Isometry3d sensor_pose(const std::string& frame, int64_t stamp_ns) const;
};

// One transform of a tf2_msgs/TFMessage: `child` in `parent` at `stamp_ns` (0 when unstamped).
struct StampedTransform {
  int64_t stamp_ns = 0;
  std::string parent, child;
  Eigen::Isometry3d parent_from_child = Eigen::Isometry3d::Identity();
};
// The message's transforms, frame ids without a leading '/'; InputError for a non-finite
// translation, a rotation that is not a finite non-zero quaternion, or an empty frame id.
std::vector<StampedTransform> from_ros2(const TFMessage& m);

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
// An initial pose, checked as Nav2 AMCL checks one (nav2_util::validateMsg, amcl_node.cpp's
// initialPoseReceived): a frame id that is the map frame (a leading '/' dropped), a finite
// position, a unit quaternion (|q|^2 within 1e-4 of 1), a finite covariance. A zero stamp is
// allowed (stamp_ns 0): `ros2 topic pub` sends one, and AMCL takes it as "now".
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
// nav2_msgs/ParticleCloud: each particle's pose and weight, as AMCL's particle_cloud.
void write(const Writer<ParticleCloud>& w, int64_t stamp_ns, const std::vector<locd::Particle2D>& particles,
           const std::string& frame_id);
// One /rosout line: `level` as Log.msg (20 INFO, 30 WARN, 40 ERROR), `name` the logger
// ("robot1.locd"), the text cut at 4095 characters.
void write(const Writer<Log>& w, int64_t stamp_ns, uint8_t level, const std::string& name, const std::string& text);
// The ROS 2 graph entry of a participant: its GID and, per node, the GIDs of its readers and
// writers (DDS GUIDs, 16 bytes).
using GidBytes = std::array<uint8_t, 16>;
struct NodeEntities {
  std::string node_namespace;  // "/robot1", "/" for the root
  std::string node_name;
  std::vector<GidBytes> readers, writers;
};
void write(const Writer<ParticipantEntitiesInfo>& w, const GidBytes& participant, const std::vector<NodeEntities>& nodes);
// A robot's sensors as its ROS 2 drivers publish them (the scan's sensor_pose stays behind: the
// receiver knows it from the frame).
void write(const Writer<ros2::LaserScan>& w, const locd::LaserScan& scan);
void write(const Writer<ros2::Odometry>& w, const locd::Odometry& odometry, const std::string& child_frame_id);

}  // namespace locd::dds::ros2
