#include "locd/server/ros2_bridge.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>
#include <sstream>
#include <utility>

#include "locd/dds/ros2_convert.hpp"
#include "locd/sdk/pose_history.hpp"
#include "locd/server/server.hpp"
#include "locd/server/transform_buffer.hpp"

namespace locd::server {
namespace {

namespace ros2 = dds::ros2;

constexpr uint8_t kRosoutInfo = 20, kRosoutWarn = 30;  // rcl_interfaces/Log.msg
constexpr int kRosoutLinesPerSecond = 5;                // per robot, as the session's log budget

bool same(const Ros2Config& a, const Ros2Config& b) {
  if (a.ros_namespace != b.ros_namespace || a.topics != b.topics || a.map_frame != b.map_frame ||
      a.base_frame != b.base_frame || a.odom_frame != b.odom_frame ||
      a.transform_tolerance_s != b.transform_tolerance_s || a.tf_broadcast != b.tf_broadcast ||
      a.odometry_timeout_s != b.odometry_timeout_s || a.particles_type != b.particles_type ||
      a.sensor_frames.size() != b.sensor_frames.size()) {
    return false;
  }
  for (const auto& [frame, pose] : a.sensor_frames) {
    const auto it = b.sensor_frames.find(frame);
    if (it == b.sensor_frames.end() || !(it->second.matrix() == pose.matrix())) return false;
  }
  return true;
}

// A ROS 2 name token from any text: [A-Za-z0-9_], not starting with a digit.
std::string name_token(const std::string& text) {
  std::string token = text.empty() ? "_" : text;
  for (char& c : token) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') c = '_';
  }
  if (std::isdigit(static_cast<unsigned char>(token.front()))) token = "_" + token;
  return token;
}

// A grid layer's topic: <grid>/<layer>.
std::string layer_topic(const std::string& grid_topic, const std::string& layer) {
  return grid_topic + "/" + name_token(layer.empty() ? "grid" : layer);
}

template <typename Wire>
std::unique_ptr<dds::Writer<Wire>> output(const dds::Participant& p, const Ros2Config& config, const char* key,
                                          dds::QosProfile profile, int depth) {
  const std::string name = config.topic(key);
  if (name.empty()) return nullptr;
  return std::make_unique<dds::Writer<Wire>>(p, ros2_dds_topic(name), profile, depth);
}

ros2::GidBytes gid_of(dds_entity_t entity) {
  dds_guid_t guid{};
  dds::check(dds_get_guid(entity, &guid), "get GUID");
  ros2::GidBytes gid{};
  std::copy(std::begin(guid.v), std::end(guid.v), gid.begin());
  return gid;
}

std::string seconds_text(double s) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(3);
  out << s << " s";
  return out.str();
}

}  // namespace

// One robot's ROS 2 endpoints and what decides its publications. The reader callbacks use the
// members declared before the readers, which are declared last: they are deleted first, waiting
// for running callbacks.
struct Ros2Bridge::Robot {
  Robot(const dds::Participant& p, Server& s, std::string id, Ros2Config ros2_config, const Limits& limits,
        Ros2Bridge& owner)
      : robot_id(std::move(id)),
        config(std::move(ros2_config)),
        frames(ros2::Frames::from(config, &tf_buffer)),
        participant(p),
        server(s),
        bridge(owner) {
    make_outputs(p);
    make_inputs(p, limits);
  }

  void make_outputs(const dds::Participant& p) {
    pose = output<ros2::PoseWithCovarianceStamped>(p, config, "pose", dds::QosProfile::kRos2Latched, 1);
    if (config.tf_broadcast) tf = output<ros2::TFMessage>(p, config, "tf", dds::QosProfile::kRos2Default, ros2::kTfDepth);
    map = output<ros2::OccupancyGrid>(p, config, "map", dds::QosProfile::kRos2Latched, 1);
    map_cloud = output<ros2::PointCloud2>(p, config, "map_cloud", dds::QosProfile::kRos2Latched, 1);
    if (config.particles_type == ParticlesType::kParticleCloud) {
      particle_cloud = output<ros2::ParticleCloud>(p, config, "particles", dds::QosProfile::kRos2Default, ros2::kDefaultDepth);
    } else {
      pose_array = output<ros2::PoseArray>(p, config, "particles", dds::QosProfile::kRos2Default, ros2::kDefaultDepth);
    }
  }

  void make_inputs(const dds::Participant& p, const Limits& limits) {
    auto measurement = [this](auto&& convert) {
      return [this, convert](const auto& message) {
        Measurement m(convert(message));
        note_stamp(header_of(m).stamp_ns);
        server.on_measurement(robot_id, std::move(m));
      };
    };
    scan = input<ros2::LaserScan>(p, "scan", dds::QosProfile::kRos2SensorData, measurement([this, &limits](const ros2::LaserScan& m) {
      return ros2::from_ros2(m, frames, limits);
    }));
    cloud = input<ros2::PointCloud2>(p, "cloud", dds::QosProfile::kRos2SensorData, measurement([this, &limits](const ros2::PointCloud2& m) {
      return ros2::from_ros2(m, frames, limits);
    }));
    image = input<ros2::Image>(p, "image", dds::QosProfile::kRos2SensorData, measurement([&limits](const ros2::Image& m) {
      return ros2::from_ros2(m, limits);
    }));
    imu = input<ros2::Imu>(p, "imu", dds::QosProfile::kRos2SensorData, measurement([this](const ros2::Imu& m) {
      return ros2::from_ros2(m, frames);
    }));
    odometry = input<ros2::Odometry>(p, "odometry", dds::QosProfile::kRos2SensorData,
                                     [this](const ros2::Odometry& m) { on_odometry(m); });
    initial_pose = input<ros2::PoseWithCovarianceStamped>(p, "initial_pose", dds::QosProfile::kRos2Default,
                                                          [this](const ros2::PoseWithCovarianceStamped& m) { on_initial_pose(m); });
    if (!config.frames_from_tf()) return;
    const bool sensors = !config.topic("scan").empty() || !config.topic("cloud").empty() || !config.topic("imu").empty();
    if (!sensors) return;
    auto transforms = [this](bool is_static) {
      return [this, is_static](const ros2::TFMessage& m) {
        for (const auto& t : ros2::from_ros2(m)) tf_buffer.add(t, is_static);
      };
    };
    tf_static_in = reader<ros2::TFMessage>(p, config.tf_static_topic(), "tf2_msgs/msg/TFMessage",
                                           dds::QosProfile::kRos2Latched, ros2::kTfDepth, transforms(true));
    tf_in = reader<ros2::TFMessage>(p, config.tf_input_topic(), "tf2_msgs/msg/TFMessage", dds::QosProfile::kRos2Default,
                                    ros2::kTfDepth, transforms(false));
  }

  // A reader of the topic of `key`, if the robot uses it.
  template <typename Wire, typename Handle>
  dds::Reader<Wire> input(const dds::Participant& p, const char* key, dds::QosProfile profile, Handle handle) {
    const std::string name = config.topic(key);
    if (name.empty()) return {};
    const int depth = profile == dds::QosProfile::kRos2SensorData ? ros2::kSensorDepth : ros2::kDefaultDepth;
    return reader<Wire>(p, name, config.ros_type(key), profile, depth, std::move(handle));
  }

  // A reader of `name`; a message `handle` refuses goes to the robot's status, naming the topic.
  template <typename Wire, typename Handle>
  dds::Reader<Wire> reader(const dds::Participant& p, const std::string& name, const char* ros_type,
                           dds::QosProfile profile, int depth, Handle handle) {
    return dds::Reader<Wire>(
        p, ros2_dds_topic(name), profile,
        [this, label = name + " (" + ros_type + ")", handle](const Wire& message) {
          try {
            handle(message);
          } catch (const std::exception& e) {
            server.on_bad_input(robot_id, label, e.what());
          }
        },
        depth);
  }

  void note_stamp(int64_t stamp) {
    std::lock_guard<std::mutex> lock(mutex);
    newest_stamp_ns = std::max(newest_stamp_ns, stamp);
  }

  void on_odometry(const ros2::Odometry& m) {
    Odometry o = ros2::from_ros2(m);
    const std::string frame = o.header.frame_id.empty() || o.header.frame_id.front() != '/' ? o.header.frame_id
                                                                                             : o.header.frame_id.substr(1);
    if (frame != config.odom_frame) {
      throw InputError("odometry: header.frame_id '" + frame + "' is not the odometry frame '" + config.odom_frame +
                       "' (ros2.odom_frame; AMCL's odom_frame_id)");
    }
    {
      std::lock_guard<std::mutex> lock(mutex);
      newest_stamp_ns = std::max(newest_stamp_ns, o.header.stamp_ns);
      odometry_history.add(o.header.stamp_ns, o.pose);
      if (pending_tf && odometry_history.newest_stamp() >= pending_tf->first) {
        write_transform_locked(pending_tf->first, pending_tf->second);
        pending_tf.reset();
      }
    }
    server.on_measurement(robot_id, Measurement(std::move(o)));
  }

  // AMCL's rules (amcl_node.cpp initialPoseReceived): the frame checked by the conversion; a zero
  // stamp means "now", as tf2's time 0 means the latest: the newest stamp the robot sent.
  void on_initial_pose(const ros2::PoseWithCovarianceStamped& m) {
    PoseEstimate pose = ros2::from_ros2(m, frames);
    if (pose.header.stamp_ns == 0) {
      std::lock_guard<std::mutex> lock(mutex);
      pose.header.stamp_ns = newest_stamp_ns > 0 ? newest_stamp_ns : wall_clock_ns();
    }
    server.on_initial_pose(robot_id, pose);
  }

  // map -> odom at `stamp`: the pose times the inverse of the odometry there, stamped
  // transform_tolerance later (AMCL's future-dating, so tf lookups at "now" need no extrapolation).
  void write_transform_locked(int64_t stamp, const Eigen::Isometry3d& map_from_base) {
    const auto odom_from_base = odometry_history.at(stamp);
    if (!tf || !odom_from_base) return;
    const int64_t expiry = stamp + static_cast<int64_t>(std::llround(config.transform_tolerance_s * 1e9));
    ros2::write(*tf, expiry, config.map_frame, config.odom_frame, map_from_base * odom_from_base->inverse());
    if (tf_withheld) {
      tf_withheld = false;
      problems.push_back({kRosoutInfo, "map -> odom on " + config.topic("tf") + " published again"});
    }
  }

  // The transform for a new pose: now if the odometry reaches its stamp, else when it does; past
  // odometry_timeout it is withheld and the status says why (once, until it is published again).
  void publish_transform(int64_t stamp, const Eigen::Isometry3d& map_from_base) {
    std::string problem;
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (odometry_history.size() > 0 && odometry_history.newest_stamp() >= stamp) {
        write_transform_locked(stamp, map_from_base);
        pending_tf.reset();
      } else {
        pending_tf.emplace(stamp, map_from_base);
        if (first_pose_ns == 0) first_pose_ns = stamp;
        const std::string odometry_topic = config.topic("odometry");
        const int64_t timeout = std::llround(config.odometry_timeout_s * 1e9);
        if (odometry_history.size() == 0 && stamp - first_pose_ns > timeout) {
          problem = "map -> odom not published: no odometry on " + odometry_topic + " in the " +
                    seconds_text(static_cast<double>(stamp - first_pose_ns) * 1e-9) + " since the first pose";
        } else if (odometry_history.size() > 0 && stamp - odometry_history.newest_stamp() > timeout) {
          problem = "map -> odom not published: the newest odometry on " + odometry_topic + " is " +
                    seconds_text(static_cast<double>(stamp - odometry_history.newest_stamp()) * 1e-9) +
                    " older than the pose (ros2.odometry_timeout = " + seconds_text(config.odometry_timeout_s) + ")";
        }
        if (problem.empty() || tf_withheld) problem.clear();
        else tf_withheld = true;
      }
    }
    if (!problem.empty()) server.on_output_problem(robot_id, problem);
  }

  // AMCL publishes no pose, particles or transform before it knows where the robot is: an initial
  // pose, or (its global localization) a converged filter. Once open it stays open.
  bool may_publish_pose(const UpdateResult& result) {
    std::string why;
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (publishing) return true;
      if (pose_known) {
        why = "the robot has an initial pose";
      } else if (result.localization && result.localization->state == LocalizationState::kTracking) {
        why = "the plugin reports tracking (" + result.localization->reason + ")";
      } else {
        return false;
      }
      publishing = true;
    }
    bridge.logger_.log(LogLevel::kInfo, robot_id, "ROS 2: publishing the pose and map -> odom from now: " + why);
    bridge.rosout(kRosoutInfo, logger_name(), "publishing the pose and map -> odom: " + why);
    return true;
  }

  void publish(const Header& header, const UpdateResult& result) {
    const std::string& map_frame = config.map_frame;
    if (result.estimate && may_publish_pose(result)) {
      if (pose) ros2::write(*pose, *result.estimate, map_frame);
      if (tf) publish_transform(result.estimate->header.stamp_ns, result.estimate->pose);
      const auto& particles = result.diagnostics.particles;
      if (!particles.empty() && particle_cloud) ros2::write(*particle_cloud, header.stamp_ns, particles, map_frame);
      if (!particles.empty() && pose_array) ros2::write(*pose_array, header.stamp_ns, particles, map_frame);
    }
    if (result.grid) publish_grid(header, *result.grid);
    if (result.map_cloud && map_cloud) ros2::write(*map_cloud, header.stamp_ns, *result.map_cloud, map_frame);
    flush_problems();
  }

  // The occupancy layer on `map` (as map_server publishes it), every layer on <grid>/<layer>.
  void publish_grid(const Header& header, const GridLayer& grid) {
    if (map && grid.layer == "occupancy") ros2::write(*map, header.stamp_ns, grid, config.map_frame);
    if (config.topic("grid").empty()) return;
    const dds::Writer<ros2::OccupancyGrid>* writer = nullptr;
    bool made = false;
    {
      std::lock_guard<std::mutex> lock(mutex);
      auto& slot = grids[grid.layer];
      if (!slot) {
        slot = std::make_unique<dds::Writer<ros2::OccupancyGrid>>(
            participant, ros2_dds_topic(layer_topic(config.topic("grid"), grid.layer)), dds::QosProfile::kRos2Latched, 1);
        made = true;
      }
      writer = slot.get();
    }
    ros2::write(*writer, header.stamp_ns, grid, config.map_frame);
    if (made) bridge.publish_discovery();
  }

  // The session's status: whether the robot holds an initial pose; a new problem goes to /rosout.
  void on_status(const SessionStatusReport& status) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (status.initial_pose_stamp_ns != 0) pose_known = true;
      if (status.last_error.empty() || status.last_error == last_error) return;
      last_error = status.last_error;
      problems.push_back({kRosoutWarn, status.last_error});
    }
    flush_problems();
  }

  // Problems noted under the lock go to /rosout, at most kRosoutLinesPerSecond a second.
  void flush_problems() {
    std::vector<std::pair<uint8_t, std::string>> lines;
    {
      std::lock_guard<std::mutex> lock(mutex);
      const auto now = std::chrono::steady_clock::now();
      if (now - rosout_window >= std::chrono::seconds(1)) rosout_window = now, rosout_lines = 0;
      for (auto& line : problems) {
        if (rosout_lines++ < kRosoutLinesPerSecond) lines.push_back(std::move(line));
      }
      problems.clear();
    }
    for (const auto& [level, text] : lines) bridge.rosout(level, logger_name(), text);
  }

  std::string logger_name() const {
    std::string name;
    std::istringstream parts(config.ros_namespace);
    for (std::string part; std::getline(parts, part, '/');) {
      if (!part.empty()) name += part + ".";
    }
    return name + node_name;
  }

  // This robot as a ROS 2 node: its namespace, name and the GIDs of its endpoints.
  ros2::NodeEntities node_entities() const {
    ros2::NodeEntities node{config.ros_namespace.empty() ? "/" : config.ros_namespace, node_name, {}, {}};
    for (const dds_entity_t r : {scan.handle(), cloud.handle(), image.handle(), imu.handle(), odometry.handle(),
                                 initial_pose.handle(), tf_static_in.handle(), tf_in.handle()}) {
      if (r) node.readers.push_back(gid_of(r));
    }
    auto add = [&](const auto& writer) {
      if (writer) node.writers.push_back(gid_of(writer->handle()));
    };
    add(pose), add(tf), add(map), add(map_cloud), add(particle_cloud), add(pose_array);
    std::lock_guard<std::mutex> lock(mutex);
    for (const auto& [_, grid] : grids) add(grid);
    return node;
  }

  // What the log says when the robot's endpoints are made.
  std::string describe() const {
    std::string reads, writes;
    for (const auto& kind : kRos2Topics) {
      std::string name = config.topic(kind.key);
      if (name.empty() || (std::string(kind.key) == "tf" && !tf)) continue;
      if (std::string(kind.key) == "grid") name += "/<layer>";
      std::string& list = kind.input ? reads : writes;
      list += (list.empty() ? "" : ", ") + name + " (" + config.ros_type(kind.key) + ")";
    }
    if (tf_in.handle()) {
      reads += (reads.empty() ? "" : ", ") + std::string("sensor frames from ") + config.tf_static_topic() + " and " +
               config.tf_input_topic();
    }
    return "ROS 2 node " + (config.ros_namespace.empty() ? "" : config.ros_namespace) + "/" + node_name + ": reads " +
           (reads.empty() ? std::string("none") : reads) + "; writes " + (writes.empty() ? std::string("none") : writes) +
           "; map -> " + config.odom_frame + " stamped " + seconds_text(config.transform_tolerance_s) +
           " after the pose (transform_tolerance)";
  }

  const std::string robot_id;
  const Ros2Config config;
  TransformBuffer tf_buffer;  // the robot's /tf_static and /tf, when sensor_frames is not given
  const ros2::Frames frames;
  const dds::Participant& participant;
  Server& server;
  Ros2Bridge& bridge;
  std::string node_name = "locd";  // set before the robot is published in ros_discovery_info

  mutable std::mutex mutex;  // guards everything below up to the grid writers
  PoseHistory odometry_history;
  int64_t newest_stamp_ns = 0;  // of any message the robot sent (a zero-stamp initial pose's stamp)
  bool pose_known = false;      // the session holds an initial pose
  bool publishing = false;      // pose, particles and map -> odom go out
  std::optional<std::pair<int64_t, Eigen::Isometry3d>> pending_tf;  // a pose waiting for odometry at its stamp
  bool tf_withheld = false;
  int64_t first_pose_ns = 0;  // the first pose waiting for odometry
  std::string last_error;  // the status's, last sent to /rosout
  std::vector<std::pair<uint8_t, std::string>> problems;  // for /rosout
  std::chrono::steady_clock::time_point rosout_window{};
  int rosout_lines = 0;
  std::map<std::string, std::unique_ptr<dds::Writer<ros2::OccupancyGrid>>> grids;

  std::unique_ptr<dds::Writer<ros2::PoseWithCovarianceStamped>> pose;
  std::unique_ptr<dds::Writer<ros2::TFMessage>> tf;
  std::unique_ptr<dds::Writer<ros2::OccupancyGrid>> map;
  std::unique_ptr<dds::Writer<ros2::PointCloud2>> map_cloud;
  std::unique_ptr<dds::Writer<ros2::ParticleCloud>> particle_cloud;
  std::unique_ptr<dds::Writer<ros2::PoseArray>> pose_array;

  dds::Reader<ros2::LaserScan> scan;
  dds::Reader<ros2::PointCloud2> cloud;
  dds::Reader<ros2::Image> image;
  dds::Reader<ros2::Imu> imu;
  dds::Reader<ros2::Odometry> odometry;
  dds::Reader<ros2::PoseWithCovarianceStamped> initial_pose;
  dds::Reader<ros2::TFMessage> tf_static_in;
  dds::Reader<ros2::TFMessage> tf_in;
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
          const bool shared_tf = (key == "tf" || key == "tf_static") && key == other_key;
          if (name != other_name || shared_tf) continue;
          throw ConfigError("ros2.topics." + key + " = '" + name + "' is robot '" + other_id + "''s " + other_key +
                            " topic already; two robots cannot share a ROS 2 topic (give each robot its own names: "
                            "a name without a leading '/' is resolved in its ros2.namespace)");
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
  if (!config.ros2 || !server) {
    publish_discovery();
    return;
  }
  std::shared_ptr<Robot> robot;
  try {
    robot = std::make_shared<Robot>(participant_, *server, robot_id, *config.ros2, limits_, *this);
  } catch (const std::exception& e) {
    throw ConfigError(std::string("ros2: the robot's ROS 2 topics could not be made: ") + e.what());
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // A node per robot: <namespace>/locd, or locd_<robot> where robots share a namespace.
    for (auto& [other_id, other] : robots_) {
      if (other->config.ros_namespace == robot->config.ros_namespace) {
        robot->node_name = "locd_" + name_token(robot_id);
        if (other->node_name == "locd") other->node_name = "locd_" + name_token(other_id);
      }
    }
    robots_[robot_id] = robot;
  }
  logger_.log(LogLevel::kInfo, robot_id, robot->describe());
  publish_discovery();
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
  publish_discovery();
}

void Ros2Bridge::publish_status(const SessionStatusReport& status) {
  next_.publish_status(status);
  std::shared_ptr<Robot> robot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = robots_.find(status.robot_id);
    if (it == robots_.end()) return;
    robot = it->second;
  }
  robot->on_status(status);
}

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

void Ros2Bridge::rosout(uint8_t level, const std::string& name, const std::string& text) {
  try {
    std::lock_guard<std::mutex> lock(graph_mutex_);
    if (!rosout_) {
      rosout_ = std::make_unique<dds::Writer<ros2::Log>>(participant_, ros2_dds_topic("/rosout"),
                                                        dds::QosProfile::kRos2Rosout, ros2::kRosoutDepth);
    }
    ros2::write(*rosout_, wall_clock_ns(), level, name, text);
  } catch (const std::exception& e) {
    logger_.log(LogLevel::kError, "server", std::string("/rosout not written: ") + e.what());
  }
}

void Ros2Bridge::publish_discovery() {
  try {
    std::vector<ros2::NodeEntities> nodes;
    {
      // Under the lock: no robot's last reference may end here (its deletion belongs to the reaper).
      std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& [_, robot] : robots_) nodes.push_back(robot->node_entities());
    }
    std::lock_guard<std::mutex> lock(graph_mutex_);
    if (!discovery_) {
      if (nodes.empty()) return;  // no ROS 2 robot yet: nothing to announce
      discovery_ = std::make_unique<dds::Writer<ros2::ParticipantEntitiesInfo>>(
          participant_, ros2::kDiscoveryTopic, dds::QosProfile::kRos2Latched, 1);
    }
    ros2::write(*discovery_, gid_of(participant_.handle()), nodes);
  } catch (const std::exception& e) {
    logger_.log(LogLevel::kError, "server", std::string("ros_discovery_info not written: ") + e.what());
  }
}

std::vector<std::string> Ros2Bridge::robots() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> ids;
  for (const auto& [id, _] : robots_) ids.push_back(id);
  return ids;
}

}  // namespace locd::server
