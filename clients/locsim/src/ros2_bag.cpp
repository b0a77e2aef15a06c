#include "locd/sim/ros2_bag.hpp"

#include <cstdio>
#include <cstdlib>
#include <optional>

#include "locd/dds/ros2.hpp"
#include "locd/dds/ros2_convert.hpp"
#include "locd/mcap/mcap.hpp"
#include "locd/mcap/wire_codec.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sdk/text.hpp"
#include "locd/sdk/validate.hpp"
#include "locd/server/transform_buffer.hpp"

namespace locd::sim {
namespace {

namespace ros2 = dds::ros2;

std::string seconds_text(int64_t stamp_ns) {
  char text[48];
  const int64_t ns = stamp_ns % 1'000'000'000;
  std::snprintf(text, sizeof text, "%s%lld.%09lld s", stamp_ns < 0 ? "-" : "", std::llabs(static_cast<long long>(stamp_ns / 1'000'000'000)),
                std::llabs(static_cast<long long>(ns)));
  return text;
}

// What the reader does with one channel of the bag.
struct ChannelUse {
  std::string key;  // ros2 key ("" = not mapped: skipped)
  const dds_topic_descriptor_t* descriptor = nullptr;
  std::optional<int64_t> last_stamp_ns;  // header.stamp of the channel's last message
};

const dds_topic_descriptor_t* descriptor_of(const std::string& key) {
  if (key == "scan") return &dds::descriptor<ros2::LaserScan>();
  if (key == "cloud") return &dds::descriptor<ros2::PointCloud2>();
  if (key == "image") return &dds::descriptor<ros2::Image>();
  if (key == "imu") return &dds::descriptor<ros2::Imu>();
  if (key == "odometry") return &dds::descriptor<ros2::Odometry>();
  return &dds::descriptor<ros2::TFMessage>();  // tf, tf_static
}

// "sensor_msgs/msg/LaserScan" as rosbag2 names it; "sensor_msgs/LaserScan" is the same type.
bool same_type(const std::string& schema_name, const std::string& ros_type) {
  if (schema_name == ros_type) return true;
  const size_t slash = ros_type.find("/msg/");
  return slash != std::string::npos && schema_name == ros_type.substr(0, slash) + "/" + ros_type.substr(slash + 5);
}

}  // namespace

BagSummary read_ros2_bag(const std::string& file, const Ros2Config& mapping, const Limits& limits,
                         const std::function<void(const BagMeasurement&)>& on_measurement) {
  std::map<std::string, std::string> key_of_topic;  // ROS 2 topic -> ros2 key
  std::string mapped_list;
  for (const char* key : kBagTopicKeys) {
    std::string topic = key == std::string("tf") ? mapping.tf_input_topic()
                        : key == std::string("tf_static") ? mapping.tf_static_topic()
                                                           : mapping.topic(key);
    if (topic.empty()) continue;
    key_of_topic[topic] = key;
    mapped_list += std::string(mapped_list.empty() ? "" : ", ") + key + " " + topic;
  }

  std::unique_ptr<mcap::Reader> reader;
  try {
    reader = std::make_unique<mcap::Reader>(file);
  } catch (const std::exception& e) {
    throw BagError(e.what());
  }
  server::TransformBuffer tf;
  // Static transforms hold at any time, and a recorder may have written the first scans before
  // the latched /tf_static: every one is read first (when frames come from tf at all).
  if (mapping.sensor_frames.empty()) {
    const std::string static_topic = mapping.tf_static_topic();
    uint64_t index = 0;
    try {
      mcap::Reader(file).read([&](const mcap::Message& m) {
        ++index;
        if (m.channel->topic != static_topic || !m.schema || !same_type(m.schema->name, "tf2_msgs/msg/TFMessage") ||
            m.channel->message_encoding != "cdr") {
          return;  // the main pass names what is wrong with it
        }
        try {
          const auto sample = mcap::decode(dds::descriptor<ros2::TFMessage>(), m.data, m.size);
          for (const auto& t : ros2::from_ros2(*static_cast<const ros2::TFMessage*>(sample.get()))) tf.add(t, true);
        } catch (const std::exception& e) {
          throw BagError(file + ": message " + std::to_string(index) + " (topic '" + escaped(static_topic) +
                         "', tf2_msgs/msg/TFMessage): " + e.what());
        }
      });
    } catch (const mcap::FormatError& e) {
      throw BagError(std::string(e.what()) + " (after message " + std::to_string(index) + ")");
    }
  }
  const ros2::Frames frames{mapping.map_frame, mapping.base_frame, mapping.sensor_frames, &tf};
  std::map<uint16_t, ChannelUse> channels;
  BagSummary summary;
  mcap::ReadSummary read;
  try {
    read = reader->read([&](const mcap::Message& m) {
      const uint64_t index = ++summary.messages;
      const std::string topic = m.channel->topic;
      const std::string where = file + ": message " + std::to_string(index) + " (topic '" + escaped(topic) + "'";
      auto it = channels.find(m.channel->id);
      if (it == channels.end()) {
        ChannelUse use;
        BagTopicSummary& t = summary.topics[topic];
        t.type = m.schema ? m.schema->name : std::string();
        const auto mapped = key_of_topic.find(topic);
        if (mapped != key_of_topic.end()) {
          use.key = mapped->second;
          t.key = use.key;
          const char* expected = mapping.ros_type(use.key);
          if (!m.schema) {
            throw BagError(where + "): channel " + std::to_string(m.channel->id) + " has no schema; the topic is mapped as " +
                           use.key + ", which needs " + expected);
          }
          if (!same_type(m.schema->name, expected)) {
            throw BagError(where + "): message type '" + escaped(m.schema->name) + "' is not " + expected +
                           ", the type of ros2 topic key '" + use.key + "'; map another topic to " + use.key +
                           " (--topic " + use.key + "=NAME) or the key to none");
          }
          if (m.channel->message_encoding != "cdr") {
            throw BagError(where + "): message encoding '" + escaped(m.channel->message_encoding) +
                           "'; a ROS 2 bag's messages are 'cdr'");
          }
          if (m.schema->encoding != "ros2msg" && m.schema->encoding != "ros2idl") {
            throw BagError(where + "): schema encoding '" + escaped(m.schema->encoding) +
                           "'; ROS 2 bags carry 'ros2msg' or 'ros2idl'");
          }
          use.descriptor = descriptor_of(use.key);
        }
        it = channels.emplace(m.channel->id, std::move(use)).first;
      }
      ChannelUse& use = it->second;
      ++summary.topics[topic].messages;
      if (use.key.empty()) return;
      const std::string what = where + ", " + mapping.ros_type(use.key) + ")";
      mcap::SamplePtr sample;
      try {
        sample = mcap::decode(*use.descriptor, m.data, m.size);
      } catch (const std::exception& e) {
        throw BagError(what + ": " + e.what());
      }
      try {
        if (use.key == "tf" || use.key == "tf_static") {
          for (const auto& t : ros2::from_ros2(*static_cast<const ros2::TFMessage*>(sample.get()))) {
            tf.add(t, use.key == "tf_static");
          }
          ++summary.transforms;
          return;
        }
        BagMeasurement out;
        out.index = index;
        out.log_time = m.log_time;
        out.topic = topic;
        const void* s = sample.get();
        if (use.key == "scan") out.measurement = ros2::from_ros2(*static_cast<const ros2::LaserScan*>(s), frames, limits);
        if (use.key == "cloud") out.measurement = ros2::from_ros2(*static_cast<const ros2::PointCloud2*>(s), frames, limits);
        if (use.key == "image") out.measurement = ros2::from_ros2(*static_cast<const ros2::Image*>(s), limits);
        if (use.key == "imu") out.measurement = ros2::from_ros2(*static_cast<const ros2::Imu*>(s), frames);
        if (use.key == "odometry") out.measurement = ros2::from_ros2(*static_cast<const ros2::Odometry*>(s));
        validate(out.measurement);
        const int64_t stamp = header_of(out.measurement).stamp_ns;
        if (use.last_stamp_ns && stamp < *use.last_stamp_ns) {
          throw InputError("header.stamp " + seconds_text(stamp) + " goes backwards: the previous message on this topic has " +
                           seconds_text(*use.last_stamp_ns));
        }
        use.last_stamp_ns = stamp;
        if (summary.measurements++ == 0) {
          summary.first_stamp_ns = stamp;
          summary.first_log_time = m.log_time;
        }
        summary.first_stamp_ns = std::min(summary.first_stamp_ns, stamp);
        summary.last_stamp_ns = std::max(summary.last_stamp_ns, stamp);
        summary.last_log_time = std::max(summary.last_log_time, m.log_time);
        on_measurement(out);
      } catch (const InputError& e) {
        throw BagError(what + ": " + e.what());
      }
    });
  } catch (const mcap::FormatError& e) {
    throw BagError(std::string(e.what()) + " (after message " + std::to_string(summary.messages) + ")");
  }
  if (!read.complete) {
    throw BagError(file + ": " + read.incomplete_reason + " (after message " + std::to_string(summary.messages) +
                   "); a bag cut short is not replayed");
  }
  if (summary.measurements == 0) {
    std::string present;
    for (const auto& [topic, t] : summary.topics) {
      present += std::string(present.empty() ? "" : ", ") + escaped(topic) + " (" + escaped(t.type) + ", " +
                 std::to_string(t.messages) + ")";
    }
    throw BagError(file + ": no message on a mapped sensor topic (mapped: " + mapped_list + "; in the bag: " +
                   (present.empty() ? "no message at all" : present) +
                   "); map the bag's topics with --topic KEY=NAME or a ros2: section (--topics FILE)");
  }
  return summary;
}

}  // namespace locd::sim
