// Conversions between the wire (idlc's C structs) and the sdk types plugins see.
// from_wire checks every network-given size against Limits *before* allocating, and rejects
// non-finite poses, inconsistent sizes and unknown encodings with an InputError that names the
// topic, the field and what is allowed.
#pragma once

#include <functional>
#include <string>

#include "locd/dds/dds.hpp"
#include "locd/sdk/plugin.hpp"
#include "locd/sdk/types.hpp"

namespace locd::dds {

Odometry from_wire(const locd_msg_Odometry& m);
Imu from_wire(const locd_msg_Imu& m);
LaserScan from_wire(const locd_msg_LaserScan& m, const Limits& limits);
PointCloud from_wire(const locd_msg_PointCloud& m, const Limits& limits);
Image from_wire(const locd_msg_Image& m, const Limits& limits);
LandmarkDetections from_wire(const locd_msg_LandmarkDetections& m, const Limits& limits);
PoseEstimate from_wire(const locd_msg_PoseEstimate& m);
PoseEstimate from_wire(const locd_msg_InitialPose& m);
ExplorationGoal from_wire(const locd_msg_ExplorationGoal& m);

Header from_wire(const locd_msg_MessageHeader& h);
Eigen::Isometry3d from_wire(const locd_msg_Pose3D& p);  // throws InputError on NaN or a zero quaternion
void to_wire(const Header& h, locd_msg_MessageHeader& out);
void to_wire(const Eigen::Isometry3d& T, locd_msg_Pose3D& out);

// Writers that publish sdk types for one robot. Buffers are borrowed from the sdk object for
// the duration of the write, so nothing is copied twice.
void write(const Writer<locd_msg_Odometry>& w, const std::string& robot_id, const Odometry& m);
void write(const Writer<locd_msg_Imu>& w, const std::string& robot_id, const Imu& m);
void write(const Writer<locd_msg_LaserScan>& w, const std::string& robot_id, const LaserScan& m);
void write(const Writer<locd_msg_PointCloud>& w, const std::string& robot_id, const PointCloud& m);
void write(const Writer<locd_msg_Image>& w, const std::string& robot_id, const Image& m);
void write(const Writer<locd_msg_LandmarkDetections>& w, const std::string& robot_id, const LandmarkDetections& m);
void write(const Writer<locd_msg_PoseEstimate>& w, const std::string& robot_id, const PoseEstimate& m,
           const std::string& plugin = "", double update_ms = 0.0);
void write(const Writer<locd_msg_InitialPose>& w, const std::string& robot_id, const PoseEstimate& m);
void write(const Writer<locd_msg_GridMap>& w, const std::string& robot_id, const Header& h, const GridLayer& g);
void write(const Writer<locd_msg_PointCloudMap>& w, const std::string& robot_id, const Header& h, const PointCloud& m);
void write(const Writer<locd_msg_LandmarkMap>& w, const std::string& robot_id, const Header& h,
           const std::vector<MapFeature>& features);
void write(const Writer<locd_msg_Diagnostics>& w, const std::string& robot_id, const Header& h,
           const std::string& plugin, const Diagnostics& d);
void write(const Writer<locd_msg_ExplorationGoal>& w, const std::string& robot_id, const ExplorationGoal& g,
           const std::string& plugin = "");

// The wire sample each write() above sends, handed to `use` instead (e.g. to serialize it into a
// recording). Its sequences borrow the sdk value's buffers: valid during the call only.
template <typename Wire>
using WireUse = std::function<void(const Wire&)>;
void to_wire(const std::string& robot_id, const Odometry& m, const WireUse<locd_msg_Odometry>& use);
void to_wire(const std::string& robot_id, const Imu& m, const WireUse<locd_msg_Imu>& use);
void to_wire(const std::string& robot_id, const LaserScan& m, const WireUse<locd_msg_LaserScan>& use);
void to_wire(const std::string& robot_id, const PointCloud& m, const WireUse<locd_msg_PointCloud>& use);
void to_wire(const std::string& robot_id, const Image& m, const WireUse<locd_msg_Image>& use);
void to_wire(const std::string& robot_id, const LandmarkDetections& m, const WireUse<locd_msg_LandmarkDetections>& use);
void to_wire(const std::string& robot_id, const PoseEstimate& m, const std::string& plugin, double update_ms,
             const WireUse<locd_msg_PoseEstimate>& use);
void to_wire(const std::string& robot_id, const PoseEstimate& m, const WireUse<locd_msg_InitialPose>& use);
void to_wire(const std::string& robot_id, const Header& h, const GridLayer& g, const WireUse<locd_msg_GridMap>& use);
void to_wire(const std::string& robot_id, const Header& h, const PointCloud& m, const WireUse<locd_msg_PointCloudMap>& use);
void to_wire(const std::string& robot_id, const Header& h, const std::vector<MapFeature>& features,
             const WireUse<locd_msg_LandmarkMap>& use);
void to_wire(const std::string& robot_id, const Header& h, const std::string& plugin, const Diagnostics& d,
             const WireUse<locd_msg_Diagnostics>& use);
void to_wire(const std::string& robot_id, const ExplorationGoal& g, const std::string& plugin,
             const WireUse<locd_msg_ExplorationGoal>& use);

}  // namespace locd::dds
