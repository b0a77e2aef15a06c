// ROS 2 bags in MCAP (what `ros2 bag record -s mcap` writes) read into sdk measurements, for
// `locsim replay BAG.mcap --config ...`. The MCAP container is locd_mcap's Reader (chunks
// uncompressed, zstd or lz4; every length bounded before allocation); the messages are CDR
// (XCDR1, as ROS 2's rmw writes them), decoded by Cyclone against idl/ros2.idl (every string and
// sequence checked against its bound and the bytes present) and converted by ros2_convert.hpp,
// the ROS 2 bridge's own conversions (Limits checked before allocation, the sdk's checks).
//
// Which topic is what comes from a `ros2:` section (sdk/ros2_config.hpp: topics scan, cloud,
// image, imu, odometry, tf, tf_static; base_frame; sensor_frames), as a ROS 2 robot's session
// config gives it; without one, Nav2 AMCL's names (/scan, /odom, /tf, /tf_static). A sensor
// frame's pose in the base frame comes from sensor_frames or, without them, from the bag's
// /tf_static (all of it read first: static transforms hold at any time, and a recorder may write
// the first scans before them) and /tf at the message's stamp (the server's TransformBuffer).
//
// Every error is a BagError naming the file, the message (its index in the file, from 1), the
// topic and the field: a mapped topic of another type, a message that does not decode or convert,
// a header.stamp going backwards on its topic, a file cut short, a bag in which no mapped topic
// holds a message.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "locd/sdk/plugin.hpp"
#include "locd/sdk/ros2_config.hpp"
#include "locd/sdk/types.hpp"

namespace locd::sim {

class BagError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The `ros2:` keys a bag replay reads: the sensors and the transforms.
inline constexpr const char* kBagTopicKeys[] = {"scan", "cloud", "image", "imu", "odometry", "tf_static", "tf"};

struct BagMeasurement {
  uint64_t index = 0;     // the message's index in the file, from 1
  uint64_t log_time = 0;  // ns, when the recorder received it
  std::string topic;      // the ROS 2 topic
  Measurement measurement;
};

struct BagTopicSummary {
  std::string type;     // the schema name, e.g. "sensor_msgs/msg/LaserScan"
  std::string key;      // the ros2 key it is mapped to ("" = not mapped)
  uint64_t messages = 0;
};

struct BagSummary {
  uint64_t messages = 0;      // every message in the file
  uint64_t measurements = 0;  // handed on
  uint64_t transforms = 0;    // tf and tf_static messages read
  int64_t first_stamp_ns = 0, last_stamp_ns = 0;  // of the measurements (header.stamp)
  uint64_t first_log_time = 0, last_log_time = 0;
  std::map<std::string, BagTopicSummary> topics;  // every topic in the file
};

// Reads `file` in file order and hands each mapped sensor message to `on_measurement`.
// `mapping`: topics by key (Ros2Config::topic), base frame, sensor frames.
BagSummary read_ros2_bag(const std::string& file, const Ros2Config& mapping, const Limits& limits,
                         const std::function<void(const BagMeasurement&)>& on_measurement);

}  // namespace locd::sim
