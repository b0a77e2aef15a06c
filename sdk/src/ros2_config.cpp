#include "locd/sdk/ros2_config.hpp"

#include <regex>

namespace locd {
namespace {

// ROS 2 names: tokens of [A-Za-z_][A-Za-z0-9_]* joined by '/', no '~' or '{}' substitutions.
constexpr size_t kMaxNameLength = 200;
constexpr size_t kMaxFrameLength = 255;  // std_msgs/Header.frame_id bound in idl/ros2.idl
constexpr double kMaxSeconds = 60.0;     // transform_tolerance, odometry_timeout

bool valid_tokens(const std::string& text) {
  static const std::regex tokens("[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*");
  return std::regex_match(text, tokens);
}

std::string resolve(const std::string& ros_namespace, const std::string& name) {
  return name.front() == '/' ? name : ros_namespace + "/" + name;
}

// A frame id; a leading '/' is dropped, as AMCL (and tf2) do.
std::string frame_text(const Params& section, const std::string& key, const std::string& default_value) {
  std::string frame = section.text(key, default_value);
  if (!frame.empty() && frame.front() == '/') frame.erase(0, 1);
  if (frame.empty() || frame.size() > kMaxFrameLength || frame.find('\0') != std::string::npos) {
    section.fail(key, "= '" + frame + "' is not allowed; expected a frame id of 1-255 characters");
  }
  return frame;
}

// The fully qualified name of a topic given under `key` of `where`.
std::string topic_name(const Params& where, const std::string& key, const std::string& ros_namespace) {
  const std::string name = where.text(key, "");
  const std::string body = !name.empty() && name.front() == '/' ? name.substr(1) : name;
  if (!valid_tokens(body)) {
    where.fail(key, "= '" + name + "' is not a ROS 2 topic name; expected names of [A-Za-z0-9_] (not "
                    "starting with a digit) joined by '/', relative to the namespace or starting with '/'");
  }
  const std::string full = resolve(ros_namespace, name);
  if (full.size() > kMaxNameLength) where.fail(key, "= '" + name + "' makes the topic '" + full + "', longer than 200 characters");
  return full;
}

void add_topic(Ros2Config& config, const Params& where, const std::string& key, const std::string& full) {
  for (const auto& [other_key, other] : config.topics) {
    if (other == full && other_key != key) {
      where.fail(key, "= '" + full + "' is the topic of '" + other_key + "' too; one topic each");
    }
  }
  config.topics[key] = full;
}

void parse_topics(const Params& section, Ros2Config& config) {
  if (!section.has("topics")) {
    for (const auto& [key, name] : kAmclTopics) config.topics[key] = resolve(config.ros_namespace, name);
    return;
  }
  const Params topics = section.child("topics");
  std::string list;
  for (const auto& kind : kRos2Topics) list += (list.empty() ? "" : ", ") + std::string(kind.key);
  if (topics.node().IsMap()) {
    for (const auto& item : topics.node()) {
      const std::string key = item.first.as<std::string>();
      bool known = false;
      for (const auto& kind : kRos2Topics) known = known || key == kind.key;
      if (!known) {
        const YAML::Mark m = item.first.Mark();
        throw ConfigError("unknown parameter '" + topics.key_path(key) + "' (line " + std::to_string(m.line + 1) +
                          ", column " + std::to_string(m.column + 1) + "); known: " + list);
      }
      add_topic(config, topics, key, topic_name(topics, key, config.ros_namespace));
    }
  }
  if (config.topics.empty()) {
    section.fail("topics", "names no topic; expected at least one of " + list + " (or no `topics` at all: AMCL's)");
  }
}

Eigen::Isometry3d pose_from_xyz_rpy(const std::vector<double>& v) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  pose.linear() = (Eigen::AngleAxisd(v[5], Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(v[4], Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(v[3], Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  return pose;
}

void parse_sensor_frames(const Params& section, Ros2Config& config) {
  const Params frames = section.child("sensor_frames");
  if (!frames.node().IsMap()) return;
  for (const auto& item : frames.node()) {
    const std::string frame = item.first.as<std::string>();
    if (frame.empty() || frame.size() > kMaxFrameLength) {
      section.fail("sensor_frames", "has the frame '" + frame + "'; expected frame ids of 1-255 characters");
    }
    if (frame == config.base_frame) frames.fail(frame, "is the base frame; a sensor in base_frame needs no pose");
    config.sensor_frames[frame] = pose_from_xyz_rpy(frames.numbers(frame, {}, 6, Range::closed(-1000.0, 1000.0)));
  }
}

// The section's keys over `config` (which holds the defaults).
void parse_section(const Params& section, Ros2Config& config) {
  section.expect_only({"namespace", "topics", "map_frame", "base_frame", "odom_frame", "sensor_frames",
                       "transform_tolerance", "tf_broadcast", "odometry_timeout", "particles_type"});
  const std::string ns = section.text("namespace", "");
  if (!ns.empty() && ns != "/") {
    const std::string body = ns.front() == '/' ? ns.substr(1) : ns;
    if (!valid_tokens(body) || body.size() > kMaxNameLength) {
      section.fail("namespace", "= '" + ns + "' is not a ROS 2 namespace; expected names of [A-Za-z0-9_] "
                                "(not starting with a digit) joined by '/', e.g. /robot1");
    }
    config.ros_namespace = "/" + body;
  }
  parse_topics(section, config);
  config.map_frame = frame_text(section, "map_frame", config.map_frame);
  config.base_frame = frame_text(section, "base_frame", config.base_frame);
  config.odom_frame = frame_text(section, "odom_frame", config.odom_frame);
  parse_sensor_frames(section, config);
  config.transform_tolerance_s =
      section.number("transform_tolerance", config.transform_tolerance_s, Range::closed(0.0, kMaxSeconds));
  config.tf_broadcast = section.flag("tf_broadcast", config.tf_broadcast);
  config.odometry_timeout_s = section.number("odometry_timeout", config.odometry_timeout_s, {0.0, kMaxSeconds, true, false});
  const std::string particles = section.text("particles_type", "nav2_msgs/msg/ParticleCloud",
                                             {"nav2_msgs/msg/ParticleCloud", "geometry_msgs/msg/PoseArray"});
  config.particles_type = particles == "geometry_msgs/msg/PoseArray" ? ParticlesType::kPoseArray : ParticlesType::kParticleCloud;
}

// What every finished section must satisfy.
void check(const Params& section, const Ros2Config& config) {
  if (config.tf_broadcast && config.topics.count("tf") && !config.topics.count("odometry")) {
    const Params topics = section.child("topics");
    const std::string what = "needs ros2.topics.odometry: the map -> odom transform is the pose times the inverse of "
                             "the odometry pose at the same stamp (or set tf_broadcast: false)";
    if (topics.has("tf")) topics.fail("tf", what);
    section.fail("topics", "tf " + what);
  }
  if (config.map_frame == config.odom_frame || config.map_frame == config.base_frame ||
      config.odom_frame == config.base_frame) {
    section.fail("map_frame", "'" + config.map_frame + "', odom_frame '" + config.odom_frame + "' and base_frame '" +
                                  config.base_frame + "' must be three different frames");
  }
}

}  // namespace

const char* const kAmclRosKeys[11] = {"base_frame_id", "global_frame_id", "odom_frame_id", "scan_topic",
                                      "map_topic", "tf_broadcast", "transform_tolerance", "use_sim_time",
                                      "save_pose_rate", "always_reset_initial_pose", "first_map_only"};

std::string Ros2Config::topic(const std::string& key) const {
  const auto it = topics.find(key);
  return it == topics.end() ? std::string() : it->second;
}

const char* Ros2Config::ros_type(const std::string& key) const {
  if (key == "particles" && particles_type == ParticlesType::kPoseArray) return "geometry_msgs/msg/PoseArray";
  for (const auto& kind : kRos2Topics) {
    if (key == kind.key) return kind.ros_type;
  }
  return "?";
}

std::string Ros2Config::tf_static_topic() const {
  const std::string name = topic("tf_static");
  return name.empty() ? "/tf_static" : name;
}

std::string Ros2Config::tf_input_topic() const {
  const std::string name = topic("tf");
  return name.empty() ? "/tf" : name;
}

std::string ros2_dds_topic(const std::string& ros_name) { return "rt" + ros_name; }

Ros2Config parse_ros2_config(const Params& section) {
  Ros2Config config;
  parse_section(section, config);
  check(section, config);
  return config;
}

Ros2Config parse_nav2_amcl(const Params& amcl, const Params* given_section) {
  const Params empty(YAML::Node(YAML::NodeType::Map), "ros2");
  const Params& section = given_section ? *given_section : empty;
  Ros2Config config;
  config.base_frame = "base_footprint";  // AMCL's base_frame_id default
  parse_section(section, config);
  // An AMCL key and the ros2 key it sets may not both be given.
  auto take = [&](const char* amcl_key, const char* ros2_key) {
    if (!amcl.has(amcl_key)) return false;
    if (section.has(ros2_key)) {
      amcl.fail(amcl_key, "sets " + section.key_path(ros2_key) + " (" + section.where(ros2_key) +
                              ") as well; give it in one place");
    }
    return true;
  };
  if (take("global_frame_id", "map_frame")) config.map_frame = frame_text(amcl, "global_frame_id", "map");
  if (take("base_frame_id", "base_frame")) config.base_frame = frame_text(amcl, "base_frame_id", "base_footprint");
  if (take("odom_frame_id", "odom_frame")) config.odom_frame = frame_text(amcl, "odom_frame_id", "odom");
  if (amcl.has("scan_topic")) {
    if (section.has("topics") && section.child("topics").has("scan")) {
      amcl.fail("scan_topic", "sets ros2.topics.scan as well; give it in one place");
    }
    add_topic(config, amcl, "scan", topic_name(amcl, "scan_topic", config.ros_namespace));
  }
  if (take("tf_broadcast", "tf_broadcast")) config.tf_broadcast = amcl.flag("tf_broadcast", true);
  if (take("transform_tolerance", "transform_tolerance")) {
    config.transform_tolerance_s = amcl.number("transform_tolerance", 1.0, Range::closed(0.0, kMaxSeconds));
  }
  // map_topic: AMCL reads map_server's map there; locd loads map_server's file itself.
  if (amcl.has("map_topic")) topic_name(amcl, "map_topic", config.ros_namespace);
  amcl.flag("use_sim_time", false);         // every time locd uses is a message's stamp
  amcl.flag("first_map_only", false);       // the map is loaded once, at configure
  amcl.number("save_pose_rate", 0.5, {});   // locd keeps the last pose in its state directory
  if (amcl.flag("always_reset_initial_pose", false)) {
    amcl.fail("always_reset_initial_pose", "= true is not supported: locd hands the robot's last pose to the plugin "
                                           "after a switch or a restart; allowed: false");
  }
  YAML::Node parameters = amcl.node();
  for (const char* key : kAmclRosKeys) parameters.remove(key);
  check(section, config);
  return config;
}

}  // namespace locd
