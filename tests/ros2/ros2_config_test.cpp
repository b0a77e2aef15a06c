// The `ros2:` section of a robot's config: names resolved as ROS 2 resolves them, every mistake
// a ConfigError naming the key, where it stands and what is allowed.
#include <gtest/gtest.h>

#include <cmath>

#include "error_of.hpp"
#include "locd/sdk/plugin_config.hpp"

using namespace locd;
using locd::test::error_of;

namespace {

PluginConfig config_of(const std::string& ros2_section) {
  return split_plugin_config("plugin: feature_ekf\nparams: {map: corridor.yaml}\nros2:\n" + ros2_section, "test.yaml");
}

std::string error_for(const std::string& ros2_section) {
  return error_of([&] { config_of(ros2_section); });
}

}  // namespace

TEST(Ros2Config, NamesResolveInTheNamespaceUnlessAbsolute) {
  const PluginConfig config = config_of(
      "  namespace: robot1\n"
      "  topics: {scan: scan, odometry: wheels/odom, initial_pose: initialpose, pose: amcl_pose, tf: /tf}\n");
  ASSERT_TRUE(config.ros2.has_value());
  const Ros2Config& r = *config.ros2;
  EXPECT_EQ(r.ros_namespace, "/robot1");
  EXPECT_EQ(r.topic("scan"), "/robot1/scan");
  EXPECT_EQ(r.topic("odometry"), "/robot1/wheels/odom");
  EXPECT_EQ(r.topic("pose"), "/robot1/amcl_pose");
  EXPECT_EQ(r.topic("tf"), "/tf");
  EXPECT_EQ(r.topic("cloud"), "");  // not used
  EXPECT_EQ(r.map_frame, "map");
  EXPECT_EQ(r.base_frame, "base_link");
  EXPECT_EQ(ros2_dds_topic(r.topic("scan")), "rt/robot1/scan");
  EXPECT_EQ(config.plugin, "feature_ekf");
  EXPECT_EQ(config.params.required_text("map"), "corridor.yaml");
}

TEST(Ros2Config, RootNamespace) {
  const Ros2Config r = *config_of("  topics: {scan: scan, pose: amcl_pose}\n").ros2;
  EXPECT_EQ(r.ros_namespace, "");
  EXPECT_EQ(r.topic("scan"), "/scan");
  EXPECT_EQ(config_of("  namespace: /\n  topics: {scan: scan}\n").ros2->topic("scan"), "/scan");
}

TEST(Ros2Config, WithoutTheSectionNothingChanges) {
  EXPECT_FALSE(split_plugin_config("plugin: feature_ekf\nparams: {map: corridor.yaml}\n", "t").ros2.has_value());
}

TEST(Ros2Config, SensorFramesAreXyzRollPitchYawInTheBaseFrame) {
  const Ros2Config r = *config_of(
                            "  topics: {scan: scan}\n"
                            "  base_frame: base_footprint\n"
                            "  sensor_frames: {laser: [0.2, -0.1, 0.3, 0.1, 0.2, 0.3]}\n")
                            .ros2;
  EXPECT_EQ(r.base_frame, "base_footprint");
  ASSERT_EQ(r.sensor_frames.count("laser"), 1u);
  const Eigen::Isometry3d& T = r.sensor_frames.at("laser");
  EXPECT_TRUE(T.translation().isApprox(Eigen::Vector3d(0.2, -0.1, 0.3)));
  // R = Rz(yaw) Ry(pitch) Rx(roll), the fixed-axis convention of ROS (REP 103), written out.
  const double cr = std::cos(0.1), sr = std::sin(0.1), cp = std::cos(0.2), sp = std::sin(0.2), cy = std::cos(0.3),
               sy = std::sin(0.3);
  Eigen::Matrix3d R;
  R << cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,  //
      sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,   //
      -sp, cp * sr, cp * cr;
  EXPECT_TRUE(T.linear().isApprox(R, 1e-12)) << T.linear() << "\n" << R;
}

TEST(Ros2Config, ErrorsNameTheKeyAndWhatIsAllowed) {
  EXPECT_NE(error_for("  topics: {scan: scan}\n  frames: {}\n").find("unknown parameter 'ros2.frames'"),
            std::string::npos);
  const std::string unknown_topic = error_for("  topics: {laser: scan}\n");
  EXPECT_NE(unknown_topic.find("unknown parameter 'ros2.topics.laser' (line 4"), std::string::npos) << unknown_topic;
  EXPECT_NE(unknown_topic.find("known: scan, cloud, image, imu, odometry, initial_pose, pose, tf, grid"),
            std::string::npos) << unknown_topic;
  const std::string bad_namespace = error_for("  namespace: 1robot\n  topics: {scan: scan}\n");
  EXPECT_NE(bad_namespace.find("'ros2.namespace'"), std::string::npos) << bad_namespace;
  EXPECT_NE(bad_namespace.find("is not a ROS 2 namespace"), std::string::npos) << bad_namespace;
  const std::string bad_name = error_for("  topics: {scan: 'my scan'}\n");
  EXPECT_NE(bad_name.find("'ros2.topics.scan'"), std::string::npos) << bad_name;
  EXPECT_NE(bad_name.find("is not a ROS 2 topic name"), std::string::npos) << bad_name;
  EXPECT_NE(error_for("  topics: {scan: scan//x}\n").find("is not a ROS 2 topic name"), std::string::npos);
  EXPECT_NE(error_for("  topics: {scan: x, cloud: x}\n").find("is the topic of 'scan' too"), std::string::npos);
  const std::string tf = error_for("  topics: {scan: scan, tf: /tf}\n");
  EXPECT_NE(tf.find("'ros2.topics.tf'"), std::string::npos) << tf;
  EXPECT_NE(tf.find("needs ros2.topics.odometry"), std::string::npos) << tf;
  EXPECT_NE(error_for("  namespace: /r\n").find("'ros2.topics' (line"), std::string::npos);
  EXPECT_NE(error_for("  namespace: /r\n").find("names no topic"), std::string::npos);
  const std::string frames = error_for("  topics: {scan: scan}\n  sensor_frames: {laser: [1, 2, 3]}\n");
  EXPECT_NE(frames.find("'ros2.sensor_frames.laser'"), std::string::npos) << frames;
  EXPECT_NE(frames.find("expected a list of 6 numbers"), std::string::npos) << frames;
  EXPECT_NE(error_for("  topics: {scan: scan}\n  sensor_frames: {base_link: [0, 0, 0, 0, 0, 0]}\n")
                .find("is the base frame"),
            std::string::npos);
  EXPECT_NE(error_for("  topics: {scan: scan}\n  map_frame: ''\n").find("'ros2.map_frame'"), std::string::npos);
  EXPECT_NE(error_of([] { split_plugin_config("plugin: feature_ekf\nros2: 3\n", "t"); }).find("'ros2'"),
            std::string::npos);
}
