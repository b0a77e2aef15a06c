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
  EXPECT_NE(unknown_topic.find("known: scan, cloud, image, imu, odometry, initial_pose, pose, tf_static, tf, map, grid"),
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
  EXPECT_NE(error_for("  namespace: /r\n  topics: {}\n").find("'ros2.topics' (line"), std::string::npos);
  EXPECT_NE(error_for("  namespace: /r\n  topics: {}\n").find("names no topic"), std::string::npos);
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

TEST(Ros2Config, WithoutTopicsAmclsDefaults) {
  // Nav2 AMCL's names (amcl_node.cpp): scan, amcl_pose, particle_cloud in the namespace; RViz's
  // /initialpose, tf2's /tf and /tf_static at the root; transform_tolerance 1.0 s, tf_broadcast.
  const Ros2Config r = *config_of("  namespace: /robot1\n").ros2;
  EXPECT_EQ(r.topic("scan"), "/robot1/scan");
  EXPECT_EQ(r.topic("odometry"), "/robot1/odom");
  EXPECT_EQ(r.topic("initial_pose"), "/initialpose");
  EXPECT_EQ(r.topic("pose"), "/robot1/amcl_pose");
  EXPECT_EQ(r.topic("particles"), "/robot1/particle_cloud");
  EXPECT_EQ(r.topic("tf"), "/tf");
  EXPECT_EQ(r.topic("tf_static"), "/tf_static");
  EXPECT_EQ(r.topic("map"), "");  // map_server publishes the map
  EXPECT_EQ(r.ros_type("particles"), std::string("nav2_msgs/msg/ParticleCloud"));
  EXPECT_EQ(r.transform_tolerance_s, 1.0);
  EXPECT_TRUE(r.tf_broadcast);
  EXPECT_EQ(r.odometry_timeout_s, 1.0);
  EXPECT_EQ(r.odom_frame, "odom");
  EXPECT_TRUE(r.frames_from_tf());

  const Ros2Config set = *config_of(
                              "  topics: {scan: scan, odometry: odom, particles: particles, map: /map}\n"
                              "  transform_tolerance: 0.3\n  tf_broadcast: false\n  odometry_timeout: 0.2\n"
                              "  odom_frame: /wheel_odom\n  particles_type: geometry_msgs/msg/PoseArray\n")
                              .ros2;
  EXPECT_EQ(set.transform_tolerance_s, 0.3);
  EXPECT_FALSE(set.tf_broadcast);
  EXPECT_EQ(set.odometry_timeout_s, 0.2);
  EXPECT_EQ(set.odom_frame, "wheel_odom");  // a leading '/' dropped, as AMCL does
  EXPECT_EQ(set.ros_type("particles"), std::string("geometry_msgs/msg/PoseArray"));
  EXPECT_EQ(set.topic("map"), "/map");
  EXPECT_EQ(set.tf_input_topic(), "/tf");
  EXPECT_EQ(set.tf_static_topic(), "/tf_static");

  EXPECT_NE(error_for("  transform_tolerance: -1\n").find("'ros2.transform_tolerance'"), std::string::npos);
  EXPECT_NE(error_for("  odometry_timeout: 0\n").find("'ros2.odometry_timeout'"), std::string::npos);
  EXPECT_NE(error_for("  particles_type: PoseArray\n").find("'ros2.particles_type'"), std::string::npos);
  EXPECT_NE(error_for("  odom_frame: map\n").find("must be three different frames"), std::string::npos);
}

namespace {

// nav2_bringup's nav2_params.yaml, amcl's section as it ships (Humble/Jazzy), with map_server
// and another node beside it.
const char* const kNav2Params = R"(amcl:
  ros__parameters:
    use_sim_time: True
    alpha1: 0.2
    alpha2: 0.2
    alpha3: 0.2
    alpha4: 0.2
    alpha5: 0.2
    base_frame_id: "base_footprint"
    beam_skip_distance: 0.5
    beam_skip_error_threshold: 0.9
    beam_skip_threshold: 0.3
    do_beamskip: false
    global_frame_id: "map"
    lambda_short: 0.1
    laser_likelihood_max_dist: 2.0
    laser_max_range: 100.0
    laser_min_range: -1.0
    laser_model_type: "likelihood_field"
    max_beams: 60
    max_particles: 2000
    min_particles: 500
    odom_frame_id: "odom"
    pf_err: 0.05
    pf_z: 0.99
    recovery_alpha_fast: 0.0
    recovery_alpha_slow: 0.0
    resample_interval: 1
    robot_model_type: "nav2_amcl::DifferentialMotionModel"
    save_pose_rate: 0.5
    sigma_hit: 0.2
    tf_broadcast: true
    transform_tolerance: 0.5
    update_min_a: 0.2
    update_min_d: 0.25
    z_hit: 0.5
    z_max: 0.05
    z_rand: 0.5
    z_short: 0.05
    scan_topic: scan
bt_navigator:
  ros__parameters:
    global_frame: map
map_server:
  ros__parameters:
    yaml_filename: "corridor_grid.yaml"
)";

std::string nav2_error(const std::string& text) {
  return error_of([&] { split_plugin_config(text, "nav2_params.yaml"); });
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  text.replace(text.find(from), from.size(), to);
  return text;
}

}  // namespace

TEST(Nav2Params, AnAmclSectionIsGridMclWithItsRosKeysInTheRos2Section) {
  const PluginConfig c = split_plugin_config(std::string(kNav2Params) + "ros2: {namespace: /robot1}\n", "nav2_params.yaml");
  EXPECT_EQ(c.plugin, "grid_mcl");
  ASSERT_TRUE(c.ros2.has_value());
  EXPECT_EQ(c.ros2->ros_namespace, "/robot1");
  EXPECT_EQ(c.ros2->base_frame, "base_footprint");
  EXPECT_EQ(c.ros2->map_frame, "map");
  EXPECT_EQ(c.ros2->odom_frame, "odom");
  EXPECT_EQ(c.ros2->transform_tolerance_s, 0.5);
  EXPECT_TRUE(c.ros2->tf_broadcast);
  EXPECT_EQ(c.ros2->topic("scan"), "/robot1/scan");
  EXPECT_EQ(c.ros2->topic("pose"), "/robot1/amcl_pose");
  // The plugin sees the filter's keys and the map, not the ROS ones.
  EXPECT_EQ(c.params.required_text("map"), "corridor_grid.yaml");
  EXPECT_EQ(c.params.number("alpha1", 0.0), 0.2);
  for (const char* key : kAmclRosKeys) EXPECT_FALSE(c.params.has(key)) << key;
  EXPECT_NE(c.params.key_path("alpha1").find("amcl.ros__parameters.alpha1"), std::string::npos);

  // AMCL's defaults where the file says nothing: base_footprint, 1.0 s.
  const PluginConfig d = split_plugin_config("amcl:\n  ros__parameters: {map: warehouse.yaml}\n", "n.yaml");
  EXPECT_EQ(d.ros2->base_frame, "base_footprint");
  EXPECT_EQ(d.ros2->transform_tolerance_s, 1.0);
  EXPECT_EQ(d.ros2->topic("scan"), "/scan");
  EXPECT_EQ(d.params.required_text("map"), "warehouse.yaml");
}

TEST(Nav2Params, EveryRosKeyHonouredOrRefusedByName) {
  const std::string tolerance = nav2_error(std::string(kNav2Params) + "ros2: {transform_tolerance: 2.0}\n");
  EXPECT_NE(tolerance.find("'amcl.ros__parameters.transform_tolerance' (line 33"), std::string::npos) << tolerance;
  EXPECT_NE(tolerance.find("sets ros2.transform_tolerance (line 47"), std::string::npos) << tolerance;
  const std::string reset = nav2_error(replaced(kNav2Params, "    scan_topic: scan\n",
                                                "    scan_topic: scan\n    always_reset_initial_pose: true\n"));
  EXPECT_NE(reset.find("'amcl.ros__parameters.always_reset_initial_pose'"), std::string::npos) << reset;
  EXPECT_NE(reset.find("= true is not supported"), std::string::npos) << reset;
  EXPECT_NE(nav2_error(replaced(kNav2Params, "scan_topic: scan", "scan_topic: 'a scan'"))
                .find("'amcl.ros__parameters.scan_topic'"),
            std::string::npos);
  EXPECT_NE(nav2_error(replaced(kNav2Params, "base_frame_id: \"base_footprint\"", "base_frame_id: \"\""))
                .find("'amcl.ros__parameters.base_frame_id'"),
            std::string::npos);
  const std::string no_map = nav2_error(replaced(kNav2Params, "    yaml_filename: \"corridor_grid.yaml\"\n", ""));
  EXPECT_NE(no_map.find("no map: give map_server.ros__parameters.yaml_filename"), std::string::npos) << no_map;
  const std::string stray = nav2_error(std::string(kNav2Params) + "plugin: feature_ekf\n");
  EXPECT_NE(stray.find("key 'plugin' (line 47) in a Nav2 params file"), std::string::npos) << stray;
  EXPECT_NE(nav2_error("amcl: {alpha1: 0.2}\n").find("unknown parameter 'amcl.alpha1'"), std::string::npos);
}
