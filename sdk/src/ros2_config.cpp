#include "locd/sdk/ros2_config.hpp"

#include <regex>

namespace locd {
namespace {

// ROS 2 names: tokens of [A-Za-z_][A-Za-z0-9_]* joined by '/', no '~' or '{}' substitutions.
constexpr size_t kMaxNameLength = 200;
constexpr size_t kMaxFrameLength = 255;  // std_msgs/Header.frame_id bound in idl/ros2.idl

bool valid_tokens(const std::string& text) {
  static const std::regex tokens("[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*");
  return std::regex_match(text, tokens);
}

std::string resolve(const std::string& ros_namespace, const std::string& name) {
  return name.front() == '/' ? name : ros_namespace + "/" + name;
}

std::string frame_text(const Params& section, const std::string& key, const std::string& default_value) {
  const std::string frame = section.text(key, default_value);
  if (frame.empty() || frame.size() > kMaxFrameLength || frame.find('\0') != std::string::npos) {
    section.fail(key, "= '" + frame + "' is not allowed; expected a frame id of 1-255 characters");
  }
  return frame;
}

}  // namespace

std::string Ros2Config::topic(const std::string& key) const {
  const auto it = topics.find(key);
  return it == topics.end() ? std::string() : it->second;
}

std::string ros2_dds_topic(const std::string& ros_name) { return "rt" + ros_name; }

Ros2Config parse_ros2_config(const Params& section) {
  section.expect_only({"namespace", "topics", "map_frame", "base_frame", "sensor_frames"});
  Ros2Config config;

  std::string ns = section.text("namespace", "");
  if (!ns.empty() && ns != "/") {
    const std::string body = ns.front() == '/' ? ns.substr(1) : ns;
    if (!valid_tokens(body) || body.size() > kMaxNameLength) {
      section.fail("namespace", "= '" + ns + "' is not a ROS 2 namespace; expected names of [A-Za-z0-9_] "
                                "(not starting with a digit) joined by '/', e.g. /robot1");
    }
    config.ros_namespace = "/" + body;
  }

  const Params topics = section.child("topics");
  std::vector<const char*> keys;
  for (const auto& kind : kRos2Topics) keys.push_back(kind.key);
  if (topics.node().IsMap()) {
    for (const auto& item : topics.node()) {
      const std::string key = item.first.as<std::string>();
      bool known = false;
      for (const auto* k : keys) known = known || key == k;
      if (!known) {
        std::string list;
        for (const auto* k : keys) list += (list.empty() ? "" : ", ") + std::string(k);
        const YAML::Mark m = item.first.Mark();
        throw ConfigError("unknown parameter '" + topics.key_path(key) + "' (line " + std::to_string(m.line + 1) +
                          ", column " + std::to_string(m.column + 1) + "); known: " + list);
      }
      const std::string name = topics.text(key, "");
      const std::string body = !name.empty() && name.front() == '/' ? name.substr(1) : name;
      if (!valid_tokens(body)) {
        topics.fail(key, "= '" + name + "' is not a ROS 2 topic name; expected names of [A-Za-z0-9_] (not "
                         "starting with a digit) joined by '/', relative to the namespace or starting with '/'");
      }
      const std::string full = resolve(config.ros_namespace, name);
      if (full.size() > kMaxNameLength) {
        topics.fail(key, "= '" + name + "' makes the topic '" + full + "', longer than 200 characters");
      }
      for (const auto& [other_key, other] : config.topics) {
        if (other == full) topics.fail(key, "= '" + name + "' is the topic of '" + other_key + "' too; one topic each");
      }
      config.topics[key] = full;
    }
  }
  if (config.topics.empty()) {
    section.fail("topics", "names no topic; expected at least one of scan, cloud, image, imu, odometry, initial_pose "
                           "(read) or pose, tf, grid, map_cloud, particles (written)");
  }
  if (config.topics.count("tf") && !config.topics.count("odometry")) {
    topics.fail("tf", "needs ros2.topics.odometry: the map -> odom transform is the pose times the inverse of the "
                      "odometry pose at the same stamp");
  }

  config.map_frame = frame_text(section, "map_frame", config.map_frame);
  config.base_frame = frame_text(section, "base_frame", config.base_frame);

  const Params frames = section.child("sensor_frames");
  if (frames.node().IsMap()) {
    for (const auto& item : frames.node()) {
      const std::string frame = item.first.as<std::string>();
      if (frame.empty() || frame.size() > kMaxFrameLength) {
        section.fail("sensor_frames", "has the frame '" + frame + "'; expected frame ids of 1-255 characters");
      }
      if (frame == config.base_frame) {
        frames.fail(frame, "is the base frame; a sensor in base_frame needs no pose");
      }
      const auto v = frames.numbers(frame, {}, 6, Range::closed(-1000.0, 1000.0));
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
      pose.linear() = (Eigen::AngleAxisd(v[5], Eigen::Vector3d::UnitZ()) *
                       Eigen::AngleAxisd(v[4], Eigen::Vector3d::UnitY()) *
                       Eigen::AngleAxisd(v[3], Eigen::Vector3d::UnitX()))
                          .toRotationMatrix();
      config.sensor_frames[frame] = pose;
    }
  }
  return config;
}

}  // namespace locd
