#include "replay.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <fstream>
#include <random>
#include <sstream>
#include <iostream>
#include <map>
#include <mutex>
#include <thread>

#include "locd/client/client.hpp"
#include "locd/dds/convert.hpp"
#include "locd/mcap/mcap.hpp"
#include "locd/mcap/wire_codec.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/plugin_loader.hpp"
#include "locd/sdk/robot_id.hpp"
#include "locd/sdk/text.hpp"
#include "locd/sdk/validate.hpp"
#include "locd/sim/reference_trajectory.hpp"
#include "locd/sim/ros2_bag.hpp"

namespace locd::sim {
namespace {

using Json = nlohmann::ordered_json;
using mcap::TopicInfo;
using Clock = std::chrono::steady_clock;

// What the replay does with one recorded channel: its locd topic and robot, or why it is skipped.
struct ChannelPlan {
  const TopicInfo* topic = nullptr;
  std::string robot_id;
  std::string problem;  // non-empty: skipped, and said why
  uint64_t messages = 0;
};

ChannelPlan plan_channel(const mcap::Channel& channel, const mcap::Schema* schema) {
  ChannelPlan plan;
  auto skip = [&](const std::string& why) {
    plan.problem = why;
    return plan;
  };
  const auto meta = channel.metadata.find(mcap::kMetaDdsTopic);
  const std::string dds_topic = meta != channel.metadata.end() ? meta->second : channel.topic;
  plan.topic = mcap::find_topic(dds_topic);
  if (!plan.topic) return skip("'" + escaped(dds_topic) + "' is not a locd topic");
  if (!schema) return skip("it has no schema");
  if (schema->encoding != mcap::kSchemaEncoding || channel.message_encoding != mcap::kMessageEncoding) {
    return skip("schema encoding '" + escaped(schema->encoding) + "', message encoding '" +
                escaped(channel.message_encoding) + "'; locsim replays omgidl / cdr");
  }
  if (schema->name != plan.topic->type_name) {
    return skip("schema '" + escaped(schema->name) + "' is not " + plan.topic->type_name + ", the type of " +
                plan.topic->topic);
  }
  if (schema->data != mcap::locd_idl()) {
    return skip("its schema text differs from this build's idl/locd.idl (recorded by another locd version): its bytes "
                "could be misread");
  }
  if (plan.topic->per_robot) {
    const auto robot = channel.metadata.find(mcap::kMetaRobotId);
    if (robot == channel.metadata.end()) return skip("it names no robot_id in its metadata");
    if (const std::string error = robot_id_error(robot->second); !error.empty()) return skip(error);
    plan.robot_id = robot->second;
  }
  return plan;
}

double yaw_of(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

// The sdk measurement of a sensor sample (from_wire bounds every size, as the server's bridge).
std::optional<Measurement> to_measurement(const TopicInfo& topic, const void* sample, const Limits& limits) {
  const std::string name = topic.topic;
  if (name == topics::kOdometry) return Measurement(dds::from_wire(*static_cast<const locd_msg_Odometry*>(sample)));
  if (name == topics::kImu) return Measurement(dds::from_wire(*static_cast<const locd_msg_Imu*>(sample)));
  if (name == topics::kScan) return Measurement(dds::from_wire(*static_cast<const locd_msg_LaserScan*>(sample), limits));
  if (name == topics::kCloud) return Measurement(dds::from_wire(*static_cast<const locd_msg_PointCloud*>(sample), limits));
  if (name == topics::kImage) return Measurement(dds::from_wire(*static_cast<const locd_msg_Image*>(sample), limits));
  if (name == topics::kDetections) {
    return Measurement(dds::from_wire(*static_cast<const locd_msg_LandmarkDetections*>(sample), limits));
  }
  return std::nullopt;
}

// Sleeps until a recorded log time is due at `rate` times real time (rate 0: never sleeps).
class Pacer {
 public:
  explicit Pacer(double rate) : rate_(rate) {}
  void wait(uint64_t log_time) {
    if (rate_ <= 0.0) return;
    if (!started_) {
      started_ = true;
      first_ = log_time;
      start_ = Clock::now();
      return;
    }
    const double t = static_cast<double>(static_cast<int64_t>(log_time - first_)) * 1e-9 / rate_;
    std::this_thread::sleep_until(start_ + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(t)));
  }

 private:
  double rate_;
  bool started_ = false;
  uint64_t first_ = 0;
  Clock::time_point start_;
};

// Poses by robot and stamp, recorded or replayed.
using PoseTrack = std::map<std::string, std::map<int64_t, Eigen::Isometry3d>>;

struct RobotReport {
  std::string plugin;
  uint64_t fed = 0, rejected = 0, no_session = 0, dropped = 0;
  std::string last_error;
};

// The replay target: offline plugins or a running locd.
class Target {
 public:
  virtual ~Target() = default;
  // Feeds one robot-input sample; returns false when the replay cannot go on (e.g. no answer).
  virtual bool feed(const TopicInfo& topic, const std::string& robot, const void* sample) = 0;
  virtual void finish() {}
  virtual PoseTrack poses() = 0;
  std::map<std::string, RobotReport> robots;
};

// ---------------------------------------------------------------------------------- offline

class OfflineTarget : public Target {
 public:
  explicit OfflineTarget(const ReplayOptions& o) : catalog_(o.plugin_directories), maps_(o.map_directories) {}

  bool feed(const TopicInfo& topic, const std::string& robot, const void* sample) override {
    Session& s = sessions_[robot];
    RobotReport& report = robots[robot];
    const std::string name = topic.topic;
    auto reject = [&](const std::string& error) {
      ++report.rejected;
      report.last_error = error;
    };
    if (name == topics::kSessionRequest) {
      const auto& q = *static_cast<const locd_msg_SessionRequest*>(sample);
      s.last_stamp.fill(std::nullopt);
      if (q.action == locd_msg_SESSION_STOP) {
        s.localizer.reset();
        return true;
      }
      const std::string source = "recorded session request " + std::to_string(q.request_id) + " for robot '" + robot + "'";
      try {
        const PluginConfig config = split_plugin_config(dds::to_string(q.config_yaml), source);
        PluginContext context;
        context.robot_id = robot;
        context.maps = maps_;
        LocalizerPtr next = create_configured(catalog_, config.plugin, context, config.params);
        if (s.last_pose) next->set_pose(*s.last_pose);
        s.localizer = std::move(next);
        report.plugin = config.plugin;
      } catch (const std::exception& e) {
        reject(std::string("session request refused: ") + e.what());  // a failed switch keeps the old plugin
      }
      return true;
    }
    if (name == topics::kInitialPose) {
      try {
        const PoseEstimate pose = dds::from_wire(*static_cast<const locd_msg_InitialPose*>(sample));
        s.last_pose = pose;
        if (s.localizer) s.localizer->set_pose(pose);
      } catch (const std::exception& e) {
        reject(std::string("initial pose rejected: ") + e.what());
      }
      return true;
    }
    std::optional<Measurement> m;
    try {
      m = to_measurement(topic, sample, limits_);
      if (!m) return true;  // a map-save request: nothing to compute offline
      validate(*m);
    } catch (const std::exception& e) {
      reject("rejected message on " + name + ": " + e.what());
      return true;
    }
    if (!s.localizer) {
      ++report.no_session;
      return true;
    }
    const size_t kind = static_cast<size_t>(m->index());
    const int64_t stamp = header_of(*m).stamp_ns;
    if (s.last_stamp[kind] && stamp < *s.last_stamp[kind]) {
      reject("stamp going backwards on " + name);
      return true;
    }
    s.last_stamp[kind] = stamp;
    ++report.fed;
    try {
      const UpdateResult update = s.localizer->update(*m);
      if (update.estimate) {
        s.last_pose = *update.estimate;
        poses_[robot][update.estimate->header.stamp_ns] = update.estimate->pose;
      }
    } catch (const InputError& e) {
      reject(std::string("plugin refused a message on ") + name + ": " + e.what());
    }
    return true;
  }

  PoseTrack poses() override { return poses_; }

 private:
  struct Session {
    LocalizerPtr localizer;
    std::optional<PoseEstimate> last_pose;
    std::array<std::optional<int64_t>, std::variant_size_v<Measurement>> last_stamp;
  };
  PluginCatalog catalog_;
  MapResolver maps_;
  Limits limits_;
  std::map<std::string, Session> sessions_;
  PoseTrack poses_;
};

// ---------------------------------------------------------------------------------- DDS

class DdsTarget : public Target {
 public:
  DdsTarget(const ReplayOptions& o, Client& client) : options_(o), client_(client), participant_(o.domain_id) {
    client_.on_pose([this](const PoseUpdate& p) {
      std::lock_guard<std::mutex> lock(mutex_);
      poses_[p.robot_id][p.estimate.header.stamp_ns] = p.estimate.pose;
      changed_.notify_all();
    });
    client_.on_status([this](const SessionStatus& s) {
      std::lock_guard<std::mutex> lock(mutex_);
      statuses_[s.robot_id].push_back(s);
      latest_received_[s.robot_id] = s.received;
      changed_.notify_all();
    });
  }

  bool feed(const TopicInfo& topic, const std::string& robot, const void* sample) override {
    RawWriter& w = writer_for(topic, robot);
    if (!w.matched) {
      const auto deadline = Clock::now() + timeout();
      while (matched_readers(w) == 0 && Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      if (matched_readers(w) == 0) {
        std::cerr << "locsim replay: no locd reads " << topic.topic << " in partition " << topics::robot_partition(robot)
                  << " on domain " << options_.domain_id << " within " << options_.server_timeout_s << " s\n";
        return false;
      }
      w.matched = true;
    }
    uint64_t received_before = 0;  // what the session had received before this write
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (const auto latest = latest_received_.find(robot); latest != latest_received_.end()) {
        received_before = latest->second;
      }
      statuses_[robot].clear();  // the answer must come after this write
    }
    dds::check(dds_write(w.writer.handle(), sample), (std::string("write ") + topic.topic).c_str());
    ++robots[robot].fed;
    const std::string name = topic.topic;
    if (name == topics::kSessionRequest) {
      const auto& q = *static_cast<const locd_msg_SessionRequest*>(sample);
      return await(robot, "the answer to session request " + std::to_string(q.request_id), [&](const SessionStatus& s) {
        if (s.request_id != q.request_id || s.state == "starting") return false;
        robots[robot].plugin = s.plugin;
        if (!s.request_ok) robots[robot].last_error = s.message;
        return true;
      });
    }
    if (name == topics::kInitialPose) {
      const int64_t stamp = static_cast<const locd_msg_InitialPose*>(sample)->header.stamp_ns;
      // Held once the session has received it: a session that runs on from an earlier replay of
      // the same file holds an initial pose of this very stamp already.
      return await(robot, "the server to hold the initial pose", [&](const SessionStatus& s) {
        return (s.initial_pose_stamp_ns == stamp && s.received > received_before) ||
               s.last_error.rfind("initial pose rejected", 0) == 0 || s.state == "no_session";
      });
    }
    return true;
  }

  void finish() override {
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // poses still in flight
    for (const auto& s : client_.statuses()) {
      if (!robots.count(s.robot_id)) continue;
      robots[s.robot_id].rejected = s.rejected;
      robots[s.robot_id].dropped = s.dropped;
      if (!s.last_error.empty()) robots[s.robot_id].last_error = s.last_error;
    }
  }

  PoseTrack poses() override {
    std::lock_guard<std::mutex> lock(mutex_);
    return poses_;
  }

  // Waits until the robot has a pose stamped `stamp_ns` or later (the session caught up with a
  // scan), at most `timeout`; false when none came.
  bool await_pose(const std::string& robot, int64_t stamp_ns, std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] {
      const auto it = poses_.find(robot);
      return it != poses_.end() && !it->second.empty() && it->second.rbegin()->first >= stamp_ns;
    });
  }

 private:
  struct RawWriter {
    dds::Entity publisher, writer;
    bool matched = false;
  };

  std::chrono::milliseconds timeout() const {
    return std::chrono::milliseconds(static_cast<int64_t>(options_.server_timeout_s * 1000));
  }

  RawWriter& writer_for(const TopicInfo& topic, const std::string& robot) {
    auto key = std::make_pair(std::string(topic.topic), robot);
    auto it = writers_.find(key);
    if (it != writers_.end()) return it->second;
    RawWriter w;
    const dds_entity_t t = dds::create_topic(participant_, *topic.descriptor, topic.topic);
    auto qos = dds::make_qos(topic.transient_local ? dds::QosProfile::kState : dds::QosProfile::kSensor, 8);
    w.publisher = dds::publisher_for(participant_, {topics::robot_partition(robot)});
    w.writer = dds::Entity(dds::check(dds_create_writer(w.publisher.handle(), t, qos.get(), nullptr),
                                      (std::string("create writer on ") + topic.topic).c_str()));
    return writers_.emplace(key, std::move(w)).first->second;
  }

  static uint32_t matched_readers(const RawWriter& w) {
    dds_publication_matched_status_t s{};
    dds_get_publication_matched_status(w.writer.handle(), &s);
    return s.current_count;
  }

  template <typename Done>
  bool await(const std::string& robot, const std::string& what, Done done) {
    std::unique_lock<std::mutex> lock(mutex_);
    const bool ok = changed_.wait_for(lock, timeout(), [&] {
      for (const auto& s : statuses_[robot]) {
        if (done(s)) return true;
      }
      return false;
    });
    if (!ok) {
      std::cerr << "locsim replay: robot '" << robot << "': no status announced " << what << " within "
                << options_.server_timeout_s << " s\n";
    }
    return ok;
  }

  const ReplayOptions& options_;
  Client& client_;
  dds::Participant participant_;
  std::map<std::pair<std::string, std::string>, RawWriter> writers_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::string, std::vector<SessionStatus>> statuses_;
  std::map<std::string, uint64_t> latest_received_;  // by robot, from its latest status
  PoseTrack poses_;
};

// ---------------------------------------------------------------------------------- ROS 2 bags

// The bag's topic mapping: --topics FILE's ros2 section, else the config's, else Nav2 AMCL's
// names; then --topic KEY=NAME and --base-frame.
Ros2Config bag_mapping(const ReplayOptions& options, const PluginConfig& config) {
  Ros2Config mapping;
  if (!options.topics_file.empty()) {
    const Params document = Params::load_file(options.topics_file);
    document.expect_only({"ros2"});
    if (!document.has("ros2")) throw ConfigError(options.topics_file + ": no ros2: section (the topic mapping)");
    mapping = parse_ros2_config(document.child("ros2"));
  } else if (config.ros2) {
    mapping = *config.ros2;
  } else {
    mapping = parse_ros2_config(Params(YAML::Node(YAML::NodeType::Map), "ros2"));
  }
  for (const std::string& o : options.topic_overrides) {
    const size_t eq = o.find('=');
    const std::string key = o.substr(0, eq);
    const bool known = std::any_of(std::begin(kBagTopicKeys), std::end(kBagTopicKeys), [&](const char* k) { return key == k; });
    if (eq == std::string::npos || !known || eq + 1 == o.size()) {
      throw ConfigError("--topic '" + escaped(o) + "': expected KEY=NAME with KEY one of scan, cloud, image, imu, odometry, "
                        "tf_static, tf and NAME a ROS 2 topic (or none)");
    }
    std::string name = o.substr(eq + 1);
    if (name == "none") {
      mapping.topics.erase(key);
      continue;
    }
    if (name.front() != '/') name = "/" + name;
    mapping.topics[key] = name;
  }
  if (!options.base_frame.empty()) mapping.base_frame = options.base_frame;
  return mapping;
}

// "X,Y,YAW" (m, m, rad) as a planar pose; ConfigError naming the option otherwise.
Eigen::Isometry3d parse_xy_yaw(const std::string& text, const std::string& option) {
  double x = 0, y = 0, yaw = 0;
  char c1 = 0, c2 = 0, rest = 0;
  std::istringstream in(text);
  if (!(in >> x >> c1 >> y >> c2 >> yaw) || c1 != ',' || c2 != ',' || (in >> rest) || !std::isfinite(x) ||
      !std::isfinite(y) || !std::isfinite(yaw)) {
    throw ConfigError(option + " '" + escaped(text) + "': expected X,Y,YAW (m, m, rad)" +
                      (option == "--initial-pose" ? " or 'reference'" : ""));
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, 0);
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

// AMCL's initial_cov defaults: 0.5 m, 0.5 m, pi/12 rad standard deviations.
PoseEstimate initial_pose_at(const Eigen::Isometry3d& pose, int64_t stamp_ns) {
  PoseEstimate p;
  p.header.stamp_ns = stamp_ns;
  p.header.frame_id = "map";
  p.pose = pose;
  p.covariance = Matrix6d::Identity() * 1e-3;
  p.covariance(0, 0) = p.covariance(1, 1) = 0.25;
  p.covariance(5, 5) = (M_PI / 12) * (M_PI / 12);
  return p;
}

template <typename T>
const char* locd_topic_of() {
  if constexpr (std::is_same_v<T, Odometry>) return topics::kOdometry;
  if constexpr (std::is_same_v<T, Imu>) return topics::kImu;
  if constexpr (std::is_same_v<T, LaserScan>) return topics::kScan;
  if constexpr (std::is_same_v<T, PointCloud>) return topics::kCloud;
  if constexpr (std::is_same_v<T, Image>) return topics::kImage;
  return topics::kDetections;
}

// What a bag replay needs, read and checked before anything is sent.
struct BagPlan {
  std::string config_text;
  PluginConfig config;
  Ros2Config mapping;
  std::optional<ReferenceTrajectory> reference;
  std::optional<PoseEstimate> start;
  BagSummary checked;
};

// Reads the robot's config, the bag (every message checked) and the reference; places the initial
// pose. Throws ConfigError or ReferenceError (or the bag's own errors) naming what is wrong.
BagPlan check_bag_replay(const ReplayOptions& options, const std::string& robot, const Limits& limits) {
  BagPlan plan;
  const BagSummary& checked = plan.checked;
  const std::optional<ReferenceTrajectory>& reference = plan.reference;
  if (const std::string error = robot_id_error(robot); !error.empty()) throw ConfigError("--robot: " + error);
  std::ifstream in(options.config_file);
  if (!in) throw ConfigError("--config " + options.config_file + ": cannot be read");
  std::stringstream text;
  text << in.rdbuf();
  plan.config_text = text.str();
  plan.config = split_plugin_config(plan.config_text, options.config_file);
  plan.mapping = bag_mapping(options, plan.config);
  if (!options.reference_file.empty()) plan.reference = ReferenceTrajectory::read_tum(options.reference_file);
  int64_t first_scan_ns = -1;
  plan.checked = read_ros2_bag(options.file, plan.mapping, limits, [&](const BagMeasurement& m) {
    if (first_scan_ns < 0 && (std::holds_alternative<LaserScan>(m.measurement) || std::holds_alternative<PointCloud>(m.measurement))) {
      first_scan_ns = header_of(m.measurement).stamp_ns;
    }
  });
  auto span = [](int64_t a, int64_t b) {
    std::ostringstream s;
    s.precision(3);
    s << std::fixed << static_cast<double>(a) * 1e-9 << " s to " << static_cast<double>(b) * 1e-9 << " s";
    return s.str();
  };
  if (reference && (reference->last_ns() < checked.first_stamp_ns || reference->first_ns() > checked.last_stamp_ns)) {
    throw ReferenceError("reference " + reference->file() + " (t from " + span(reference->first_ns(), reference->last_ns()) +
                         ") does not overlap the bag " + options.file + " (header.stamp from " +
                         span(checked.first_stamp_ns, checked.last_stamp_ns) + "): not the same log, or not the same clock");
  }
  if (options.initial_pose == "reference") {
    if (!reference) throw ConfigError("--initial-pose reference needs --reference");
    const int64_t at = first_scan_ns >= 0 ? first_scan_ns : checked.first_stamp_ns;
    const auto pose = reference->at(at);
    if (!pose) {
      throw ReferenceError("reference " + reference->file() + " holds no pose at the bag's first scan (" +
                           std::to_string(static_cast<double>(at) * 1e-9) + " s) for --initial-pose reference");
    }
    Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
    if (!options.initial_offset.empty()) offset = parse_xy_yaw(options.initial_offset, "--initial-offset");
    plan.start = initial_pose_at(*pose * offset, at);
  } else if (!options.initial_pose.empty()) {
    if (!options.initial_offset.empty()) throw ConfigError("--initial-offset applies to --initial-pose reference");
    plan.start = initial_pose_at(parse_xy_yaw(options.initial_pose, "--initial-pose"), checked.first_stamp_ns);
  } else if (!options.initial_offset.empty()) {
    throw ConfigError("--initial-offset applies to --initial-pose reference");
  }
  return plan;
}

// Where the replay goes: through the plugin here (--offline), or into the running locd that
// `client` finds; null (said on stderr) when no server answers.
std::unique_ptr<Target> make_target(const ReplayOptions& options, std::unique_ptr<Client>& client) {
  if (options.offline) return std::make_unique<OfflineTarget>(options);
  client = std::make_unique<Client>(ClientOptions{options.domain_id, "", 8, {"*"}});
  if (!client->wait_for_server(std::chrono::milliseconds(static_cast<int64_t>(options.server_timeout_s * 1000)))) {
    std::cerr << "locsim replay: no locd server answered on DDS domain " << options.domain_id << " within "
              << options.server_timeout_s << " s (is locd running with the same CYCLONEDDS_URI and domain?)\n";
    return nullptr;
  }
  return std::make_unique<DdsTarget>(options, *client);
}

// A bag replay's report (what --json prints) as text.
void print_bag_replay(const Json& out, const std::optional<AbsolutePoseError>& ape, std::ostream& log) {
  const std::string last_error = out["last_error"];
  log << "replayed " << out["replayed"] << " of " << out["measurements"] << " sensor messages ("
      << out["bag_span_s"].get<double>() << " s of bag) in " << out["wall_s"].get<double>() << " s, "
      << (out["mode"] == "offline" ? "offline" : "into locd") << "; robot " << out["robot"].get<std::string>() << " ("
      << out["plugin"].get<std::string>() << "): " << out["poses"] << " poses, rejected " << out["rejected"]
      << ", dropped " << out["dropped"] << (last_error.empty() ? "" : " (last: " + last_error + ")") << "\n";
  if (ape) {
    log << "APE against " << out["reference"].get<std::string>() << " (" << ape->poses << " poses, " << ape->not_covered
        << " outside the reference): RMSE " << ape->rmse_m << " m, mean " << ape->mean_m << " m, median " << ape->median_m
        << " m, max " << ape->max_m << " m; heading RMSE " << ape->heading_rmse_deg << " deg; "
        << 100.0 * ape->share_over_half_metre << " % over 0.5 m; RPE (1 pose apart, " << ape->rpe_pairs
        << " pairs): RMSE " << ape->rpe_rmse_m << " m, max " << ape->rpe_max_m << " m\n";
  }
}

int run_bag_replay(const ReplayOptions& options) {
  std::ostream& log = options.json ? std::cerr : std::cout;
  const std::string robot = options.robots.empty() ? "robot1" : options.robots.front();
  const Limits limits;
  BagPlan plan;
  try {  // everything is checked before anything is sent
    plan = check_bag_replay(options, robot, limits);
  } catch (const std::exception& e) {
    std::cerr << "locsim replay: " << e.what() << "\n";
    return 1;
  }
  const std::string& config_text = plan.config_text;
  const PluginConfig& config = plan.config;
  const BagSummary& checked = plan.checked;

  std::unique_ptr<Client> client;
  const std::unique_ptr<Target> target = make_target(options, client);
  if (!target) return 2;
  const auto wall_start = Clock::now();
  bool stopped = false;
  {
    auto request = std::make_unique<locd_msg_SessionRequest>();
    if (config_text.size() > topics::kMaxConfigYamlBytes) {
      std::cerr << "locsim replay: --config " << options.config_file << " is " << config_text.size() << " bytes; "
                << topics::kSessionRequest << " allows at most " << topics::kMaxConfigYamlBytes << "\n";
      return 1;
    }
    dds::copy_string(request->robot_id, robot);
    dds::copy_string(request->plugin, config.plugin);
    dds::borrow_text(request->config_yaml, config_text, topics::kMaxConfigYamlBytes);
    request->action = locd_msg_SESSION_START;
    request->request_id = std::random_device()() | 1u;
    stopped = !target->feed(*mcap::find_topic(topics::kSessionRequest), robot, request.get());
    if (!stopped && !target->robots[robot].last_error.empty()) {
      std::cerr << "locsim replay: the session request for robot '" << robot << "' was refused: "
                << target->robots[robot].last_error << "\n";
      return 1;
    }
  }
  if (!stopped && plan.start) {
    dds::to_wire(robot, *plan.start, [&](const locd_msg_InitialPose& w) {
      stopped = !target->feed(*mcap::find_topic(topics::kInitialPose), robot, &w);
    });
  }
  Pacer pacer(options.rate.value_or(options.offline ? 0.0 : 1.0));
  // --fast into locd: as fast as the session keeps up, no drop: each scan waits for its pose.
  auto* keep_up = !options.offline && options.rate && *options.rate == 0.0 ? static_cast<DdsTarget*>(target.get()) : nullptr;
  const auto pose_wait = std::chrono::milliseconds(static_cast<int64_t>(std::min(options.server_timeout_s, 2.0) * 1000));
  uint64_t replayed = 0, scans_without_pose = 0;
  struct StopReplay {};
  try {
    if (!stopped) {
      read_ros2_bag(options.file, plan.mapping, limits, [&](const BagMeasurement& m) {
        pacer.wait(m.log_time);
        std::visit(
            [&](const auto& value) {
              using T = std::decay_t<decltype(value)>;
              dds::to_wire(robot, value, [&](const auto& wire) {
                if (!target->feed(*mcap::find_topic(locd_topic_of<T>()), robot, &wire)) stopped = true;
              });
            },
            m.measurement);
        ++replayed;
        if (keep_up && !stopped &&
            (std::holds_alternative<LaserScan>(m.measurement) || std::holds_alternative<PointCloud>(m.measurement)) &&
            !keep_up->await_pose(robot, header_of(m.measurement).stamp_ns, pose_wait)) {
          ++scans_without_pose;
        }
        if (stopped) throw StopReplay{};
      });
    }
  } catch (const StopReplay&) {
  } catch (const std::exception& e) {  // the file changed since it was checked
    std::cerr << "locsim replay: " << e.what() << "\n";
    return 1;
  }
  target->finish();
  const double wall_s = std::chrono::duration<double>(Clock::now() - wall_start).count();
  const double span_s = static_cast<double>(checked.last_log_time - checked.first_log_time) * 1e-9;
  const PoseTrack track = target->poses();
  const auto& poses = track.count(robot) ? track.at(robot) : std::map<int64_t, Eigen::Isometry3d>{};
  const RobotReport& report = target->robots[robot];

  Json topics_json = Json::object();
  for (const auto& [topic, t] : checked.topics) {
    topics_json[escaped(topic)] = {{"type", escaped(t.type)}, {"mapped_as", t.key}, {"messages", t.messages}};
  }
  Json out = {{"file", options.file}, {"kind", "ros2_bag"}, {"mode", options.offline ? "offline" : "dds"},
              {"robot", robot}, {"plugin", report.plugin.empty() ? config.plugin : report.plugin},
              {"messages", checked.messages}, {"measurements", checked.measurements}, {"transforms", checked.transforms},
              {"replayed", replayed}, {"topics", topics_json}, {"bag_span_s", span_s}, {"wall_s", wall_s},
              {"speed_x_real_time", wall_s > 0 ? span_s / wall_s : 0.0}, {"fed", report.fed},
              {"rejected", report.rejected}, {"dropped", report.dropped}, {"last_error", report.last_error},
              {"scans_without_pose", scans_without_pose},
              {"poses", poses.size()}};
  std::optional<AbsolutePoseError> ape;
  if (plan.reference) {
    ape = absolute_pose_error(poses, *plan.reference);
    out["reference"] = options.reference_file;
    out["ape"] = {{"poses", ape->poses}, {"not_covered", ape->not_covered}, {"rmse_m", ape->rmse_m},
                  {"mean_m", ape->mean_m}, {"median_m", ape->median_m}, {"max_m", ape->max_m},
                  {"heading_rmse_deg", ape->heading_rmse_deg}, {"heading_max_deg", ape->heading_max_deg},
                  {"share_over_0_5_m", ape->share_over_half_metre}};
    out["rpe"] = {{"pairs", ape->rpe_pairs}, {"rmse_m", ape->rpe_rmse_m}, {"mean_m", ape->rpe_mean_m},
                  {"median_m", ape->rpe_median_m}, {"max_m", ape->rpe_max_m}};
  }
  if (options.json) {
    std::cout << out.dump() << "\n";
  } else {
    print_bag_replay(out, ape, log);
  }
  if (stopped) return 2;
  if (poses.empty()) {
    std::cerr << "locsim replay: robot '" << robot << "' got no pose from the replay"
              << (report.last_error.empty() ? "" : " (last error: " + report.last_error + ")") << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

namespace {

// Stamp by stamp: the poses the replay produced against the poses recorded, per robot;
// `every_robot_posed` says whether each robot replayed got at least one pose.
Json compare_with_recording(Target& target, const PoseTrack& recorded, bool& every_robot_posed) {
  const PoseTrack replayed_poses = target.poses();
  Json robots = Json::array();
  every_robot_posed = !target.robots.empty();
  for (const auto& [robot, report] : target.robots) {
    const auto& mine = replayed_poses.count(robot) ? replayed_poses.at(robot) : std::map<int64_t, Eigen::Isometry3d>{};
    const auto& theirs = recorded.count(robot) ? recorded.at(robot) : std::map<int64_t, Eigen::Isometry3d>{};
    size_t matched = 0, identical = 0;  // identical: within 1e-9 m and 1e-9 rad
    double max_position = 0.0, sum_position = 0.0, max_yaw = 0.0;
    for (const auto& [stamp, pose] : mine) {
      const auto r = theirs.find(stamp);
      if (r == theirs.end()) continue;
      ++matched;
      const double d = (pose.translation() - r->second.translation()).norm();
      const double dyaw = std::abs(std::remainder(yaw_of(pose) - yaw_of(r->second), 2.0 * M_PI));
      max_position = std::max(max_position, d);
      sum_position += d;
      max_yaw = std::max(max_yaw, dyaw);
      if (d <= 1e-9 && dyaw <= 1e-9) ++identical;
    }
    if (mine.empty()) every_robot_posed = false;
    robots.push_back({{"robot", robot}, {"plugin", report.plugin}, {"fed", report.fed}, {"rejected", report.rejected},
                      {"no_session", report.no_session}, {"last_error", report.last_error},
                      {"poses", mine.size()}, {"recorded_poses", theirs.size()}, {"matched", matched}, {"identical", identical},
                      {"max_position_diff_m", max_position},
                      {"mean_position_diff_m", matched ? sum_position / static_cast<double>(matched) : 0.0},
                      {"max_yaw_diff_rad", max_yaw}});
  }
  return robots;
}

// The replay's report (what --json prints) as text.
void print_replay(const Json& out, std::ostream& log) {
  const double input_s = out["replayed_span_s"], wall_s = out["wall_s"];
  log << "replayed " << out["replayed"] << " of " << out["messages"] << " messages (" << input_s << " s of the "
      << out["recorded_span_s"].get<double>() << " s recorded) in " << wall_s << " s ("
      << (wall_s > 0 ? input_s / wall_s : 0.0) << "x real time), "
      << (out["mode"] == "offline" ? "offline" : "into locd") << "\n";
  for (const auto& r : out["robots"]) {
    log << "  " << r["robot"].get<std::string>() << " (" << r["plugin"].get<std::string>() << "): " << r["poses"]
        << " poses, " << r["matched"] << " at recorded stamps (" << r["identical"] << " identical), max difference "
        << r["max_position_diff_m"] << " m / " << r["max_yaw_diff_rad"] << " rad; rejected " << r["rejected"]
        << (r["last_error"].get<std::string>().empty() ? "" : " (last: " + r["last_error"].get<std::string>() + ")")
        << "\n";
  }
}

}  // namespace

int run_replay(const ReplayOptions& options) {
  if (!options.config_file.empty()) return run_bag_replay(options);
  std::ostream& log = options.json ? std::cerr : std::cout;
  mcap::Reader reader(options.file);  // FormatError for a file that is not MCAP
  std::unique_ptr<Client> client;
  const std::unique_ptr<Target> target = make_target(options, client);
  if (!target) return 2;
  Pacer pacer(options.rate.value_or(options.offline ? 0.0 : 1.0));

  std::map<uint16_t, ChannelPlan> plans;
  PoseTrack recorded;
  uint64_t messages = 0, replayed = 0, undecodable = 0, first_log = 0, last_log = 0, first_input = 0, last_input = 0;
  std::string last_undecodable, format_error;
  bool stopped = false;
  mcap::ReadSummary summary;
  const auto wall_start = Clock::now();
  try {
    summary = reader.read([&](const mcap::Message& m) {
      if (stopped) return;
      if (messages++ == 0) first_log = m.log_time;
      last_log = std::max(last_log, m.log_time);
      auto it = plans.find(m.channel->id);
      if (it == plans.end()) {
        it = plans.emplace(m.channel->id, plan_channel(*m.channel, m.schema)).first;
        if (!it->second.problem.empty()) {
          std::cerr << "locsim replay: skipping channel '" << escaped(m.channel->topic) << "': " << it->second.problem << "\n";
        }
      }
      ChannelPlan& plan = it->second;
      if (!plan.problem.empty()) return;
      ++plan.messages;
      if (!options.robots.empty() && plan.topic->per_robot &&
          std::find(options.robots.begin(), options.robots.end(), plan.robot_id) == options.robots.end()) {
        return;
      }
      const bool pose = std::string(plan.topic->topic) == topics::kPose;
      if (!pose && !plan.topic->robot_input) return;
      mcap::SamplePtr sample;
      try {
        sample = mcap::decode(*plan.topic->descriptor, m.data, m.size);
      } catch (const std::exception& e) {
        ++undecodable;
        last_undecodable = "channel '" + escaped(m.channel->topic) + "': " + e.what();
        return;
      }
      if (plan.topic->per_robot && std::string(static_cast<const char*>(sample.get())) != plan.robot_id) {  // robot_id: first member
        ++undecodable;
        last_undecodable = "channel '" + escaped(m.channel->topic) + "' holds a sample of another robot";
        return;
      }
      if (pose) {
        const auto& p = *static_cast<const locd_msg_PoseEstimate*>(sample.get());
        try {
          recorded[plan.robot_id][p.header.stamp_ns] = dds::from_wire(p.pose);
        } catch (const std::exception&) {
        }
        return;
      }
      pacer.wait(m.log_time);
      if (replayed++ == 0) first_input = m.log_time;
      last_input = m.log_time;
      if (!target->feed(*plan.topic, plan.robot_id, sample.get())) stopped = true;
    });
  } catch (const mcap::FormatError& e) {
    format_error = e.what();
  }
  target->finish();
  const double wall_s = std::chrono::duration<double>(Clock::now() - wall_start).count();
  const double span_s = static_cast<double>(last_log - first_log) * 1e-9;        // the whole recording
  const double input_s = static_cast<double>(last_input - first_input) * 1e-9;  // what was replayed

  bool every_robot_posed = false;
  const Json robots = compare_with_recording(*target, recorded, every_robot_posed);
  Json skipped = Json::array();
  for (const auto& [id, plan] : plans) {
    if (!plan.problem.empty()) skipped.push_back({{"channel", id}, {"reason", plan.problem}});
  }
  Json out = {{"file", options.file},
              {"mode", options.offline ? "offline" : "dds"},
              {"messages", messages},
              {"replayed", replayed},
              {"undecodable", undecodable},
              {"last_undecodable", last_undecodable},
              {"skipped_channels", skipped},
              {"recording_complete", summary.complete},
              {"incomplete_reason", format_error.empty() ? summary.incomplete_reason : format_error},
              {"recorded_span_s", span_s},
              {"replayed_span_s", input_s},
              {"wall_s", wall_s},
              {"speed_x_real_time", wall_s > 0 ? input_s / wall_s : 0.0},
              {"robots", robots}};
  if (options.json) {
    std::cout << out.dump() << "\n";
  } else {
    print_replay(out, log);
  }
  if (!format_error.empty()) {
    std::cerr << "locsim replay: " << format_error << "; the " << replayed << " messages before it were replayed\n";
    return 1;
  }
  if (!summary.complete) std::cerr << "locsim replay: warning: " << options.file << ": " << summary.incomplete_reason << "\n";
  if (undecodable > 0) std::cerr << "locsim replay: " << undecodable << " messages not decodable, last: " << last_undecodable << "\n";
  if (stopped) return 2;
  if (!every_robot_posed) {
    std::cerr << "locsim replay: " << (target->robots.empty() ? "the recording holds no robot input to replay"
                                                              : "a robot got no pose from the replay") << "\n";
    return 1;
  }
  return 0;
}

}  // namespace locd::sim
