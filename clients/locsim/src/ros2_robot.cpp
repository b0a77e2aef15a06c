#include "locd/sim/ros2_robot.hpp"

#include <sstream>
#include <stdexcept>

#include "locd/dds/ros2_convert.hpp"
#include "locd/sdk/ros2_config.hpp"

namespace locd::sim {
namespace {

namespace ros2 = dds::ros2;

std::string topic(const std::string& ros_namespace, const std::string& name) {
  return ros2_dds_topic(ros_namespace + "/" + name);
}

}  // namespace

Ros2Robot::Ros2Robot(const dds::Participant& participant, Ros2RobotOptions options, PoseCallback on_pose,
                     TransformCallback on_transform)
    : options_(std::move(options)),
      scan_(participant, topic(options_.ros_namespace, "scan"), options_.sensor_qos, ros2::kSensorDepth),
      odometry_(participant, topic(options_.ros_namespace, "odom"), options_.sensor_qos, ros2::kSensorDepth),
      initial_pose_(participant, topic(options_.ros_namespace, "initialpose"), dds::QosProfile::kRos2Default,
                    ros2::kDefaultDepth),
      pose_(participant, topic(options_.ros_namespace, "amcl_pose"), dds::QosProfile::kRos2Latched,
            [on_pose = std::move(on_pose)](const ros2::PoseWithCovarianceStamped& m) {
              PoseEstimate p;
              try {
                p.header = {ros2::stamp_ns(m.header.stamp), ros2::frame_id(m.header)};
              } catch (const std::exception&) {
                return;  // unstamped: not one of locd's poses
              }
              const auto& q = m.pose.pose.orientation;
              p.pose = Eigen::Translation3d(m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z) *
                       Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized();
              for (int k = 0; k < 36; ++k) p.covariance(k / 6, k % 6) = m.pose.covariance[k];
              on_pose(p);
            }) {
  if (on_transform) {
    tf_ = dds::Reader<ros2::TFMessage>(
        participant, ros2_dds_topic("/tf"), dds::QosProfile::kRos2Default,
        [on_transform = std::move(on_transform)](const ros2::TFMessage& m) {
          for (uint32_t i = 0; i < m.transforms._length; ++i) {
            const auto& t = m.transforms._buffer[i];
            const auto& r = t.transform.rotation;
            const auto& p = t.transform.translation;
            const Eigen::Isometry3d T = Eigen::Translation3d(p.x, p.y, p.z) * Eigen::Quaterniond(r.w, r.x, r.y, r.z);
            if (t.header.stamp.sec == 0 && t.header.stamp.nanosec == 0) continue;
            on_transform(ros2::stamp_ns(t.header.stamp), ros2::frame_id(t.header), dds::to_string(t.child_frame_id), T);
          }
        },
        ros2::kTfDepth);
  }
}

std::string Ros2Robot::config_section(const std::string& ros_namespace, const std::string& laser_frame,
                                      const Eigen::Isometry3d& laser_pose) {
  const Eigen::Vector3d p = laser_pose.translation();
  const Eigen::Vector3d rpy = laser_pose.linear().eulerAngles(2, 1, 0);  // yaw, pitch, roll
  std::ostringstream s;
  s.precision(17);
  s << "ros2:\n"
    << "  namespace: " << ros_namespace << "\n"
    << "  topics: {scan: scan, odometry: odom, initial_pose: initialpose, pose: amcl_pose, tf: /tf}\n"
    << "  sensor_frames: {" << laser_frame << ": [" << p.x() << ", " << p.y() << ", " << p.z() << ", " << rpy[2]
    << ", " << rpy[1] << ", " << rpy[0] << "]}\n";
  return s.str();
}

void Ros2Robot::publish(const Measurement& measurement) {
  if (const auto* scan = std::get_if<LaserScan>(&measurement)) {
    ros2::write(scan_, *scan);
  } else if (const auto* odometry = std::get_if<Odometry>(&measurement)) {
    ros2::write(odometry_, *odometry, options_.base_frame);
  } else {
    throw std::invalid_argument(std::string("a ROS 2 robot here publishes odometry and scans, not ") +
                                kind_name(kind_of(measurement)));
  }
}

void Ros2Robot::publish_initial_pose(const PoseEstimate& pose) { ros2::write(initial_pose_, pose, "map"); }

bool Ros2Robot::matched() const {
  return scan_.matched() > 0 && odometry_.matched() > 0 && initial_pose_.matched() > 0 && pose_.matched() > 0;
}

}  // namespace locd::sim
