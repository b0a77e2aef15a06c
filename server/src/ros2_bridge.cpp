#include "locd/server/ros2_bridge.hpp"

#include <cctype>
#include <utility>

#include "locd/dds/ros2_convert.hpp"
#include "locd/server/pose_history.hpp"
#include "locd/server/server.hpp"

namespace locd::server {
namespace {

namespace ros2 = dds::ros2;

const char* ros_type(const std::string& key) {
  for (const auto& kind : kRos2Topics) {
    if (key == kind.key) return kind.ros_type;
  }
  return "?";
}

bool same(const Ros2Config& a, const Ros2Config& b) {
  if (a.ros_namespace != b.ros_namespace || a.topics != b.topics || a.map_frame != b.map_frame ||
      a.base_frame != b.base_frame || a.sensor_frames.size() != b.sensor_frames.size()) {
    return false;
  }
  for (const auto& [frame, pose] : a.sensor_frames) {
    const auto it = b.sensor_frames.find(frame);
    if (it == b.sensor_frames.end() || !(it->second.matrix() == pose.matrix())) return false;
  }
  return true;
}

// A grid layer's topic: <grid>/<layer>, the layer name made a ROS 2 name token.
std::string layer_topic(const std::string& grid_topic, const std::string& layer) {
  std::string token = layer.empty() ? "grid" : layer;
  for (char& c : token) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') c = '_';
  }
  if (std::isdigit(static_cast<unsigned char>(token.front()))) token = "_" + token;
  return grid_topic + "/" + token;
}

template <typename Wire>
std::unique_ptr<dds::Writer<Wire>> output(const dds::Participant& p, const Ros2Config& config, const char* key,
                                          dds::QosProfile profile, int depth) {
  const std::string name = config.topic(key);
  if (name.empty()) return nullptr;
  return std::make_unique<dds::Writer<Wire>>(p, ros2_dds_topic(name), profile, depth);
}

}  // namespace

// One robot's ROS 2 endpoints. The reader callbacks use the members declared before the readers,
// which are declared last: they are deleted first, waiting for running callbacks.
struct Ros2Bridge::Robot {
  Robot(const dds::Participant& p, Server& server, std::string id, Ros2Config ros2_config, const Limits& limits)
      : robot_id(std::move(id)), config(std::move(ros2_config)), frames(ros2::Frames::from(config)), participant(p) {
    pose = output<ros2::PoseWithCovarianceStamped>(p, config, "pose", dds::QosProfile::kRos2Latched, 1);
    tf = output<ros2::TFMessage>(p, config, "tf", dds::QosProfile::kRos2Default, ros2::kTfDepth);
    map_cloud = output<ros2::PointCloud2>(p, config, "map_cloud", dds::QosProfile::kRos2Latched, 1);
    particles = output<ros2::PoseArray>(p, config, "particles", dds::QosProfile::kRos2Default, ros2::kDefaultDepth);

    auto measurement = [this, &server](auto&& convert) {
      return [this, &server, convert](const auto& message) {
        server.on_measurement(robot_id, Measurement(convert(message)));
      };
    };
    scan = input<ros2::LaserScan>(p, server, "scan", dds::QosProfile::kRos2SensorData, measurement([this, &limits](const ros2::LaserScan& m) {
      return ros2::from_ros2(m, frames, limits);
    }));
    cloud = input<ros2::PointCloud2>(p, server, "cloud", dds::QosProfile::kRos2SensorData, measurement([this, &limits](const ros2::PointCloud2& m) {
      return ros2::from_ros2(m, frames, limits);
    }));
    image = input<ros2::Image>(p, server, "image", dds::QosProfile::kRos2SensorData, measurement([&limits](const ros2::Image& m) {
      return ros2::from_ros2(m, limits);
    }));
    imu = input<ros2::Imu>(p, server, "imu", dds::QosProfile::kRos2SensorData, measurement([this](const ros2::Imu& m) {
      return ros2::from_ros2(m, frames);
    }));
    odometry = input<ros2::Odometry>(p, server, "odometry", dds::QosProfile::kRos2SensorData, [this, &server](const ros2::Odometry& m) {
      Odometry o = ros2::from_ros2(m);
      {
        std::lock_guard<std::mutex> lock(mutex);
        odometry_history.add(o.header.stamp_ns, o.pose);
        odometry_frame = o.header.frame_id;
      }
      server.on_measurement(robot_id, Measurement(std::move(o)));
    });
    initial_pose = input<ros2::PoseWithCovarianceStamped>(p, server, "initial_pose", dds::QosProfile::kRos2Default,
        [this, &server](const ros2::PoseWithCovarianceStamped& m) { server.on_initial_pose(robot_id, ros2::from_ros2(m, frames)); });
  }

  // A reader of the topic of `key`, if the robot uses it; a message `handle` refuses goes to the
  // robot's status, naming the ROS 2 topic and type.
  template <typename Wire, typename Handle>
  dds::Reader<Wire> input(const dds::Participant& p, Server& server, const char* key, dds::QosProfile profile,
                          Handle handle) {
    const std::string name = config.topic(key);
    if (name.empty()) return {};
    const int depth = profile == dds::QosProfile::kRos2SensorData ? ros2::kSensorDepth : ros2::kDefaultDepth;
    return dds::Reader<Wire>(
        p, ros2_dds_topic(name), profile,
        [this, &server, label = name + " (" + ros_type(key) + ")", handle](const Wire& message) {
          try {
            handle(message);
          } catch (const std::exception& e) {
            server.on_bad_input(robot_id, label, e.what());
          }
        },
        depth);
  }

  void publish(const Header& header, const UpdateResult& result) {
    const std::string& map_frame = config.map_frame;
    if (result.estimate && pose) ros2::write(*pose, *result.estimate, map_frame);
    if (result.estimate && tf) {
      std::optional<Eigen::Isometry3d> odom_from_base;
      std::string odom_frame;
      {
        std::lock_guard<std::mutex> lock(mutex);
        odom_from_base = odometry_history.at(result.estimate->header.stamp_ns);
        odom_frame = odometry_frame;
      }
      if (odom_from_base) {
        ros2::write(*tf, result.estimate->header.stamp_ns, map_frame, odom_frame,
                    result.estimate->pose * odom_from_base->inverse());
      }
    }
    if (result.grid && !config.topic("grid").empty()) {
      const dds::Writer<ros2::OccupancyGrid>* writer = nullptr;
      {
        std::lock_guard<std::mutex> lock(mutex);
        auto& slot = grids[result.grid->layer];
        if (!slot) {
          slot = std::make_unique<dds::Writer<ros2::OccupancyGrid>>(
              participant, ros2_dds_topic(layer_topic(config.topic("grid"), result.grid->layer)),
              dds::QosProfile::kRos2Latched, 1);
        }
        writer = slot.get();
      }
      ros2::write(*writer, header.stamp_ns, *result.grid, map_frame);
    }
    if (result.map_cloud && map_cloud) ros2::write(*map_cloud, header.stamp_ns, *result.map_cloud, map_frame);
    if (!result.diagnostics.particles.empty() && particles) {
      ros2::write(*particles, header.stamp_ns, result.diagnostics.particles, map_frame);
    }
  }

  // What the log says when the robot's endpoints are made.
  std::string describe() const {
    std::string reads, writes;
    for (const auto& kind : kRos2Topics) {
      const std::string name = config.topic(kind.key);
      if (name.empty()) continue;
      std::string& list = kind.input ? reads : writes;
      list += (list.empty() ? "" : ", ") + name + " (" + kind.ros_type + ")";
    }
    return "ROS 2 topics: reads " + (reads.empty() ? std::string("none") : reads) + "; writes " +
           (writes.empty() ? std::string("none") : writes);
  }

  const std::string robot_id;
  const Ros2Config config;
  const ros2::Frames frames;
  const dds::Participant& participant;

  std::mutex mutex;  // guards the odometry history and frame, and the grid writers
  PoseHistory odometry_history;
  std::string odometry_frame;
  std::map<std::string, std::unique_ptr<dds::Writer<ros2::OccupancyGrid>>> grids;

  std::unique_ptr<dds::Writer<ros2::PoseWithCovarianceStamped>> pose;
  std::unique_ptr<dds::Writer<ros2::TFMessage>> tf;
  std::unique_ptr<dds::Writer<ros2::PointCloud2>> map_cloud;
  std::unique_ptr<dds::Writer<ros2::PoseArray>> particles;

  dds::Reader<ros2::LaserScan> scan;
  dds::Reader<ros2::PointCloud2> cloud;
  dds::Reader<ros2::Image> image;
  dds::Reader<ros2::Imu> imu;
  dds::Reader<ros2::Odometry> odometry;
  dds::Reader<ros2::PoseWithCovarianceStamped> initial_pose;
};

Ros2Bridge::Ros2Bridge(const dds::Participant& participant, const Limits& limits, OutputSink& next, Logger& logger)
    : participant_(participant), limits_(limits), next_(next), logger_(logger),
      reaper_([this] { reaper_loop(); }) {}

Ros2Bridge::~Ros2Bridge() {
  disconnect();
  {
    std::lock_guard<std::mutex> lock(retired_mutex_);
    stopping_ = true;
  }
  retired_changed_.notify_all();
  reaper_.join();
}

void Ros2Bridge::retire(std::shared_ptr<Robot> robot) {
  {
    std::lock_guard<std::mutex> lock(retired_mutex_);
    retired_.push_back(std::move(robot));
  }
  retired_changed_.notify_all();
}

void Ros2Bridge::reap() {
  std::unique_lock<std::mutex> lock(retired_mutex_);
  for (;;) {
    if (!retired_.empty()) {
      std::vector<std::shared_ptr<Robot>> batch;
      batch.swap(retired_);
      ++deleting_;
      lock.unlock();
      batch.clear();
      lock.lock();
      --deleting_;
      retired_changed_.notify_all();
    } else if (deleting_ > 0) {
      retired_changed_.wait(lock);
    } else {
      return;
    }
  }
}

void Ros2Bridge::reaper_loop() {
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(retired_mutex_);
      retired_changed_.wait(lock, [this] { return stopping_ || !retired_.empty(); });
      if (stopping_ && retired_.empty()) return;
    }
    reap();
  }
}

void Ros2Bridge::connect(Server& server) {
  std::lock_guard<std::mutex> lock(mutex_);
  server_ = &server;
}

void Ros2Bridge::disconnect() {
  std::lock_guard<std::mutex> config_lock(config_mutex_);
  std::map<std::string, std::shared_ptr<Robot>> robots;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    server_ = nullptr;
    robots.swap(robots_);
  }
  for (auto& [_, robot] : robots) retire(std::move(robot));
  reap();  // outside the locks: deleting a reader waits for its callbacks
}

void Ros2Bridge::session_configured(const std::string& robot_id, const PluginConfig& config) {
  std::lock_guard<std::mutex> config_lock(config_mutex_);
  Server* server = nullptr;
  std::shared_ptr<Robot> current;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    server = server_;
    if (const auto it = robots_.find(robot_id); it != robots_.end()) current = it->second;
  }
  if (current && config.ros2 && same(current->config, *config.ros2)) return;
  if (config.ros2) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [other_id, other] : robots_) {
      if (other_id == robot_id) continue;
      for (const auto& [key, name] : config.ros2->topics) {
        for (const auto& [other_key, other_name] : other->config.topics) {
          if (name != other_name || (key == "tf" && other_key == "tf")) continue;
          throw ConfigError("ros2.topics." + key + " = '" + name + "' is robot '" + other_id + "''s " + other_key +
                            " topic already; two robots cannot share a ROS 2 topic (give each robot its own "
                            "ros2.namespace)");
        }
      }
    }
  }
  if (current) {
    // The old endpoints go before the new ones come: no message is taken twice, and a topic may
    // change its type.
    {
      std::lock_guard<std::mutex> lock(mutex_);
      robots_.erase(robot_id);
    }
    retire(std::move(current));
    logger_.log(LogLevel::kInfo, robot_id, "ROS 2 topics removed");
  }
  reap();  // on a worker: the endpoints retired so far are gone before new ones are made
  if (!config.ros2 || !server) return;
  std::shared_ptr<Robot> robot;
  try {
    robot = std::make_shared<Robot>(participant_, *server, robot_id, *config.ros2, limits_);
  } catch (const std::exception& e) {
    throw ConfigError(std::string("ros2: the robot's ROS 2 topics could not be made: ") + e.what());
  }
  logger_.log(LogLevel::kInfo, robot_id, robot->describe());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    robots_[robot_id] = robot;
  }
  // A stop that came while these endpoints were made: its session_ended found nothing to remove.
  // (One that comes after this check finds them.)
  if (!server->find(robot_id)) session_ended(robot_id);
}

void Ros2Bridge::session_ended(const std::string& robot_id) {
  // Often on a DDS listener thread: no config_mutex_ (a worker holding it may be deleting
  // endpoints, which waits for this thread) and no deletion here.
  std::shared_ptr<Robot> robot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = robots_.find(robot_id);
    if (it == robots_.end()) return;
    robot = std::move(it->second);
    robots_.erase(it);
  }
  retire(std::move(robot));
  logger_.log(LogLevel::kInfo, robot_id, "ROS 2 topics removed");
}

void Ros2Bridge::publish_status(const SessionStatusReport& status) { next_.publish_status(status); }

void Ros2Bridge::publish_server_info(const ServerInfoReport& info) { next_.publish_server_info(info); }

void Ros2Bridge::publish_outputs(const std::string& robot_id, const std::string& plugin, const Header& header,
                                 const UpdateResult& result, double update_ms) {
  next_.publish_outputs(robot_id, plugin, header, result, update_ms);
  std::shared_ptr<Robot> robot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = robots_.find(robot_id);
    if (it == robots_.end()) return;
    robot = it->second;
  }
  try {
    robot->publish(header, result);
  } catch (const std::exception& e) {
    logger_.log(LogLevel::kError, robot_id, std::string("ROS 2 outputs not published: ") + e.what());
  }
}

std::vector<std::string> Ros2Bridge::robots() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> ids;
  for (const auto& [id, _] : robots_) ids.push_back(id);
  return ids;
}

}  // namespace locd::server
