// locd as a Nav2 stack's AMCL (issue 24), seen from a ROS 2 robot on eProsima Fast DDS 2.9 as
// rmw_fastrtps runs one: the types are fastddsgen's from idl/ros2.idl and idl/locd.idl, the
// names, QoS and frames are a Nav2 robot's, and locd's config is a Nav2 params file (amcl:
// ros__parameters) with map_server's map. No Cyclone DDS and no locd code in this program (the
// simulated robot is locd_sim, plain C++). Domain 217.
//
// The program is the robot and its Nav2 stack at once: robot_state_publisher's /tf_static, the
// base controller's /odom and odom -> base_footprint on /tf, the laser's /scan, RViz's "2D Pose
// Estimate" on the global /initialpose with a zero stamp, and what Nav2's costmaps and controller
// do with tf: look up map -> base_footprint at their own "now", as tf2 would, without
// extrapolation. It also reads what `ros2 node list` and `ros2 topic info -v` read
// (ros_discovery_info against DDS discovery) and what rqt_console reads (/rosout).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <thread>

#include "eventually.hpp"
#include "fastdds_participant.hpp"
#include "locd.h"
#include "locdPubSubTypes.h"
#include "ros2PubSubTypes.h"
#include "locd/sim/scenario.hpp"
#include "locd/sim/simulation.hpp"
#include "test_server.hpp"

using namespace std::chrono_literals;
using namespace locd::test;
namespace fs = std::filesystem;
namespace geometry = geometry_msgs::msg::dds_;
namespace wire = locd::msg;

namespace {

constexpr int kDomain = 217;
const char* const kRobot = "nav2bot";

// nav2_params.yaml for this robot: grid_mcl's shipped corridor settings as amcl's
// ros__parameters, AMCL's ROS keys as Nav2 ships them, and map_server's map.
std::string nav2_params() {
  YAML::Node params = YAML::LoadFile(source_dir() + "/config/plugins/grid_mcl.yaml")["params"];
  const std::string map = params["map"].as<std::string>();
  params.remove("map");
  params["base_frame_id"] = "base_footprint";
  params["global_frame_id"] = "map";
  params["odom_frame_id"] = "odom";
  params["scan_topic"] = "scan";
  params["tf_broadcast"] = true;
  params["transform_tolerance"] = 1.0;
  params["use_sim_time"] = false;
  params["save_pose_rate"] = 0.5;
  YAML::Node document;
  document["amcl"]["ros__parameters"] = params;
  document["map_server"]["ros__parameters"]["yaml_filename"] = map;
  YAML::Emitter out;
  out << document;
  return out.c_str();
}

// One link of tf2's buffer: samples by stamp; a lookup interpolates between the two around the
// time asked (translation linearly, rotation by slerp) and fails outside them, as tf2's
// lookupTransform throws ExtrapolationException.
class Link {
 public:
  void add(int64_t stamp, const Eigen::Isometry3d& T) { samples_[stamp] = T; }
  std::optional<Eigen::Isometry3d> at(int64_t t) const {
    const auto after = samples_.lower_bound(t);
    if (after == samples_.end()) return std::nullopt;
    if (after->first == t) return after->second;
    if (after == samples_.begin()) return std::nullopt;
    const auto before = std::prev(after);
    const double s = static_cast<double>(t - before->first) / static_cast<double>(after->first - before->first);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = (1 - s) * before->second.translation() + s * after->second.translation();
    T.linear() = Eigen::Quaterniond(before->second.linear()).slerp(s, Eigen::Quaterniond(after->second.linear())).toRotationMatrix();
    return T;
  }
  bool empty() const { return samples_.empty(); }
  int64_t newest() const { return samples_.rbegin()->first; }

 private:
  std::map<int64_t, Eigen::Isometry3d> samples_;
};

Eigen::Isometry3d planar(double x, double y, double z, double yaw) {
  return Eigen::Translation3d(x, y, z) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
}

// The robot's side of DDS: what its drivers, robot_state_publisher and RViz write, and what its
// Nav2 stack reads.
struct Nav2Robot {
  explicit Nav2Robot(FastDds& dds)
      : tf_static(dds.writer<tf2_msgs::msg::dds_::TFMessage_PubSubType>("rt/tf_static", "", FastQos{true, true, 1})),
        tf(dds.writer<tf2_msgs::msg::dds_::TFMessage_PubSubType>("rt/tf", "", FastQos{true, false, 100})),
        scan(dds.writer<sensor_msgs::msg::dds_::LaserScan_PubSubType>("rt/scan", "", FastQos{false, false, 5})),
        odom(dds.writer<nav_msgs::msg::dds_::Odometry_PubSubType>("rt/odom", "", FastQos{false, false, 5})),
        initial_pose(dds.writer<geometry::PoseWithCovarianceStamped_PubSubType>("rt/initialpose", "", FastQos{true, false, 1})),
        tf_in(dds.reader<tf2_msgs::msg::dds_::TFMessage_PubSubType>("rt/tf", "", FastQos{true, false, 1000})),
        amcl_pose(dds.reader<geometry::PoseWithCovarianceStamped_PubSubType>("rt/amcl_pose", "", FastQos{true, true, 1000})),
        particles(dds.reader<nav2_msgs::msg::dds_::ParticleCloud_PubSubType>("rt/particle_cloud", "", FastQos{false, false, 5})),
        rosout(dds.reader<rcl_interfaces::msg::dds_::Log_PubSubType>("rt/rosout", "", FastQos{true, true, 1000})),
        graph(dds.reader<rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_PubSubType>("ros_discovery_info", "",
                                                                                         FastQos{true, true, 1})),
        status(dds.reader<wire::SessionStatusPubSubType>("locd/session_status", std::string("robot.") + kRobot,
                                                         FastQos{true, true, 8})) {}

  bool ok() const { return tf_static && tf && scan && odom && initial_pose && tf_in && amcl_pose && particles && rosout && graph && status; }

  void send(const std::vector<std::tuple<std::string, std::string, Eigen::Isometry3d>>& links, int64_t stamp,
            fdds::DataWriter* writer) {
    tf2_msgs::msg::dds_::TFMessage_ m;
    for (const auto& [parent, child, T] : links) {
      geometry::TransformStamped_ t;
      to_fast(stamp, parent, t.header());
      t.child_frame_id() = child;
      const Eigen::Quaterniond q(T.linear());
      t.transform().translation().x(T.translation().x());
      t.transform().translation().y(T.translation().y());
      t.transform().translation().z(T.translation().z());
      t.transform().rotation().x(q.x());
      t.transform().rotation().y(q.y());
      t.transform().rotation().z(q.z());
      t.transform().rotation().w(q.w());
      m.transforms().push_back(t);
    }
    writer->write(&m);
  }

  // Everything that arrived: map -> odom into the tf buffer, poses, particles, /rosout lines, the
  // session's status (its localization state and initial pose).
  void take() {
    take_all<tf2_msgs::msg::dds_::TFMessage_>(tf_in, [&](const tf2_msgs::msg::dds_::TFMessage_& m) {
      for (const auto& t : m.transforms()) {
        if (t.header().frame_id().to_string() == "map" && t.child_frame_id().to_string() == "odom") {
          map_odom.add(from_fast(t.header().stamp()), from_fast(t.transform()));
          ++transforms;
        }
      }
    });
    take_all<geometry::PoseWithCovarianceStamped_>(amcl_pose, [&](const geometry::PoseWithCovarianceStamped_&) { ++poses; });
    take_all<nav2_msgs::msg::dds_::ParticleCloud_>(particles, [&](const nav2_msgs::msg::dds_::ParticleCloud_& m) {
      if (m.header().frame_id().to_string() == "map" && !m.particles().empty()) ++particle_clouds;
    });
    take_all<rcl_interfaces::msg::dds_::Log_>(rosout, [&](const rcl_interfaces::msg::dds_::Log_& m) {
      logs.push_back({m.level(), m.name().to_string() + ": " + m.msg().to_string()});
    });
    take_all<wire::SessionStatus>(status, [&](const wire::SessionStatus& s) {
      if (s.localization() == wire::LOCALIZATION_TRACKING && first_tracking_ns == 0) first_tracking_ns = s.header().stamp_ns();
      initial_pose_stamp = s.initial_pose_stamp_ns();
      last_error = s.last_error().to_string();
    });
  }

  bool logged(uint8_t level, const std::string& text) const {
    return std::any_of(logs.begin(), logs.end(), [&](const auto& l) { return l.first == level && l.second.find(text) != std::string::npos; });
  }

  fdds::DataWriter *tf_static, *tf, *scan, *odom, *initial_pose;
  fdds::DataReader *tf_in, *amcl_pose, *particles, *rosout, *graph, *status;
  Link map_odom;
  size_t transforms = 0, poses = 0, particle_clouds = 0;
  std::vector<std::pair<uint8_t, std::string>> logs;
  int64_t first_tracking_ns = 0;  // when the session first reported tracking (its status's wall clock)
  int64_t initial_pose_stamp = 0;
  std::string last_error;
};

}  // namespace

namespace {

// `ros2 node list` and `ros2 topic info -v`: rmw pairs the GIDs a participant lists in
// ros_discovery_info with the endpoints DDS discovery shows. locd's participant must list a node
// /locd holding the GUID of each of its endpoints on the robot's topics, and nothing else.
void expect_locd_in_the_ros2_graph(const FastDds& dds, Nav2Robot& robot) {
  rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_ info;
  ASSERT_TRUE(eventually([&] {
    take_all<rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_>(robot.graph, [&](const auto& m) { info = m; });
    return !info.node_entities_info_seq().empty();
  })) << "no ros_discovery_info from locd";
  const auto& gid = info.gid().data();
  auto locds = [&](const std::set<Guid>& endpoints) {  // those of locd's participant
    std::set<Guid> out;
    for (const Guid& g : endpoints) {
      if (std::equal(g.begin(), g.begin() + 12, gid.begin())) out.insert(g);
    }
    return out;
  };
  ASSERT_EQ(info.node_entities_info_seq().size(), 1u);
  const auto& node = info.node_entities_info_seq()[0];
  EXPECT_EQ(node.node_namespace().to_string(), "/");
  EXPECT_EQ(node.node_name().to_string(), "locd");
  std::set<Guid> writers, readers;
  for (const auto& g : node.writer_gid_seq()) writers.insert(g.data());
  for (const auto& g : node.reader_gid_seq()) readers.insert(g.data());
  std::set<Guid> seen_writers, seen_readers;
  for (const char* topic : {"rt/amcl_pose", "rt/tf", "rt/particle_cloud"}) {
    std::set<Guid> discovered;
    EXPECT_TRUE(eventually([&] { return !(discovered = locds(dds.writers_on(topic))).empty(); }, 10s)) << topic;
    EXPECT_EQ(discovered.size(), 1u) << topic;
    for (const Guid& g : discovered) EXPECT_EQ(writers.count(g), 1u) << "locd's writer on " << topic << " is not in its node";
    seen_writers.insert(discovered.begin(), discovered.end());
  }
  for (const char* topic : {"rt/scan", "rt/odom", "rt/initialpose", "rt/tf_static", "rt/tf"}) {
    std::set<Guid> discovered;
    EXPECT_TRUE(eventually([&] { return !(discovered = locds(dds.readers_on(topic))).empty(); }, 10s)) << topic;
    for (const Guid& g : discovered) EXPECT_EQ(readers.count(g), 1u) << "locd's reader on " << topic << " is not in its node";
    seen_readers.insert(discovered.begin(), discovered.end());
  }
  EXPECT_EQ(writers, seen_writers);
  EXPECT_EQ(readers, seen_readers);
}

void publish(Nav2Robot& robot, const locd::Measurement& m) {
  if (const auto* o = std::get_if<locd::Odometry>(&m)) {
    nav_msgs::msg::dds_::Odometry_ w;
    to_fast(o->header.stamp_ns, "odom", w.header());
    w.child_frame_id() = "base_footprint";
    to_fast(o->pose, w.pose().pose());
    w.twist().twist().linear().x(o->linear_velocity.x());
    w.twist().twist().angular().z(o->angular_velocity.z());
    robot.odom->write(&w);
    robot.send({{"odom", "base_footprint", o->pose}}, o->header.stamp_ns, robot.tf);  // the base controller's tf
  } else if (const auto* s = std::get_if<locd::LaserScan>(&m)) {
    sensor_msgs::msg::dds_::LaserScan_ w;
    to_fast(s->header.stamp_ns, "laser", w.header());
    w.angle_min(s->angle_min);
    w.angle_increment(s->angle_increment);
    w.angle_max(static_cast<float>(s->angle(s->ranges.size() - 1)));
    w.range_min(s->range_min);
    w.range_max(s->range_max);
    w.ranges(s->ranges);
    robot.scan->write(&w);
  }
}

// RViz's "2D Pose Estimate": /initialpose, unstamped here (as `ros2 topic pub` sends it), RViz's
// covariance (0.25 m^2, 0.25 m^2, 0.0685 rad^2).
void estimate_pose(Nav2Robot& robot, const locd::Pose2& pose, const std::string& frame) {
  geometry::PoseWithCovarianceStamped_ m;
  m.header().frame_id() = frame;
  to_fast(pose.to_isometry(), m.pose().pose());
  m.pose().covariance()[0] = m.pose().covariance()[7] = 0.25;
  m.pose().covariance()[35] = 0.06853891945200942;
  robot.initial_pose->write(&m);
}

}  // namespace

TEST(Nav2Stack, LocdServesANav2RobotAsAmclDoes) {
  const fs::path params_file = fs::temp_directory_path() / ("nav2_params_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(params_file) << nav2_params();
  TestServerOptions options;
  options.extra_config = std::string("sessions:\n  - robot_id: ") + kRobot + "\n    config_file: " + params_file.string() + "\n";
  TestServer locd("nav2_stack", kDomain, options);
  FastDds dds(kDomain);
  ASSERT_TRUE(dds.ok());
  Nav2Robot robot(dds);
  ASSERT_TRUE(robot.ok());
  ASSERT_TRUE(eventually([&] {
    return matched(robot.scan) && matched(robot.odom) && matched(robot.initial_pose) && matched(robot.tf_static);
  })) << locd.process().output();
  expect_locd_in_the_ros2_graph(dds, robot);

  // robot_state_publisher: base_footprint -> base_link -> laser; the corridor's laser is 0.2 m ahead.
  robot.send({{"base_footprint", "base_link", planar(0, 0, 0.1, 0)}, {"base_link", "laser", planar(0.2, 0, -0.1, 0)}},
             wall_ns(), robot.tf_static);

  // The robot drives in real time. For 3 s it has no initial pose; then a pose in the wrong frame
  // (refused), then RViz's; from the first lookup that succeeds, 30 s of lookups every 50 ms.
  constexpr double kBefore = 3.0, kWindow = 30.0;
  constexpr int64_t kLookupPeriod = 50'000'000;
  const locd::sim::Scenario scenario = locd::sim::load_scenario(source_dir() + "/config/scenarios/corridor_grid.yaml");
  locd::sim::Simulation simulation(scenario, scenario.seed, kBefore + 15.0 + kWindow, 0);
  const int64_t origin = wall_ns();
  const auto start = std::chrono::steady_clock::now();
  Link odom_base;
  size_t poses_before = 0, transforms_before = 0;
  int64_t initial_sent_ns = 0, next_lookup = 0;
  std::optional<int64_t> window_start;
  size_t lookups = 0, failures = 0;
  double squared_error = 0.0, least_lead_s = 1e9;  // how far the newest map -> odom was ahead of now
  std::string first_failure;
  while (auto m = simulation.next()) {
    std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                              std::chrono::duration<double>(m->t)));
    const int64_t stamp = origin + static_cast<int64_t>(std::llround(m->t * 1e9));
    std::visit([&](auto& v) { v.header.stamp_ns = stamp; }, m->measurement);
    publish(robot, m->measurement);
    const auto* odometry = std::get_if<locd::Odometry>(&m->measurement);
    if (!odometry) continue;
    odom_base.add(stamp, odometry->pose);
    robot.take();
    if (initial_sent_ns == 0 && m->t >= kBefore - 1.0 && robot.initial_pose_stamp == 0 && robot.logs.empty()) {
      estimate_pose(robot, simulation.truth().at(m->t).pose, "odom");  // refused: not the map frame
    }
    if (initial_sent_ns == 0 && m->t >= kBefore) {
      poses_before = robot.poses;
      transforms_before = robot.transforms;
      initial_sent_ns = wall_ns();
      estimate_pose(robot, simulation.truth().at(m->t).pose * locd::Pose2(0.2, -0.1, 0.03), "map");
      next_lookup = stamp;
    }
    if (initial_sent_ns == 0 || stamp < next_lookup) continue;
    // Nav2's lookup of map -> base_footprint at its "now": the odometry it just stamped.
    next_lookup += kLookupPeriod;
    const auto map_odom = robot.map_odom.at(stamp);
    if (!window_start) {
      if (!map_odom) continue;
      window_start = stamp;
    }
    if (stamp >= *window_start + static_cast<int64_t>(kWindow * 1e9)) break;
    ++lookups;
    if (!map_odom) {
      if (failures++ == 0) {
        first_failure = "at " + std::to_string((stamp - *window_start) * 1e-9) + " s into the window: newest map -> odom " +
                        (robot.map_odom.empty() ? std::string("none") : std::to_string((robot.map_odom.newest() - stamp) * 1e-9) + " s after now");
      }
      continue;
    }
    least_lead_s = std::min(least_lead_s, (robot.map_odom.newest() - stamp) * 1e-9);
    const Eigen::Isometry3d map_base = *map_odom * *odom_base.at(stamp);
    const locd::Pose2 truth = simulation.truth().at(m->t).pose;
    squared_error += (map_base.translation().head<2>() - Eigen::Vector2d(truth.x, truth.y)).squaredNorm();
  }
  robot.take();

  EXPECT_NE(robot.initial_pose_stamp, 0) << "RViz's unstamped /initialpose was not applied: " << robot.last_error;
  ASSERT_TRUE(window_start.has_value()) << "no lookup of map -> base_footprint ever succeeded\n" << locd.process().output();
  EXPECT_GE(lookups, static_cast<size_t>(0.9 * kWindow * 1e9 / kLookupPeriod));
  EXPECT_EQ(failures, 0u) << failures << " of " << lookups << " lookups would extrapolate; first " << first_failure;
  const double rmse = std::sqrt(squared_error / static_cast<double>(lookups - failures));
  EXPECT_LT(rmse, 0.2);
  std::printf("nav2_stack: %zu lookups of map -> base_footprint at now in %.0f s, %zu would extrapolate; newest map -> "
              "odom at least %.3f s ahead of now; RMSE %.3f m\n",
              lookups, kWindow, failures, least_lead_s, rmse);
  // Nothing before the initial pose, unless the plugin's global localization converged first.
  if (!(robot.first_tracking_ns > 0 && robot.first_tracking_ns < initial_sent_ns)) {
    EXPECT_EQ(poses_before, 0u);
    EXPECT_EQ(transforms_before, 0u);
  }
  EXPECT_GT(robot.poses, 0u);
  EXPECT_GT(robot.particle_clouds, 0u);
  // The refusal and the start of publication, as rqt_console shows them.
  EXPECT_TRUE(robot.logged(30, "locd: rejected message on /initialpose (geometry_msgs/msg/PoseWithCovarianceStamped): "
                               "initial pose: frame 'odom' is not the map frame 'map'"))
      << (robot.logs.empty() ? "no /rosout line" : robot.logs.front().second);
  EXPECT_TRUE(robot.logged(20, "locd: publishing the pose and map -> odom"));
  EXPECT_TRUE(locd.process().running());
  fs::remove(params_file);
}
