#include "locd/client/client.hpp"
#include "locd/client/wire.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <condition_variable>
#include <cmath>
#include <cstring>
#include <iostream>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>
#include <utility>

#include "locd/dds/convert.hpp"
#include "locd/dds/dds.hpp"
#include "locd/dds/topics.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sdk/robot_id.hpp"
#include "locd/sdk/text.hpp"

namespace locd {
namespace {

int64_t wall_clock_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string state_name(locd_msg_SessionState state) {
  switch (state) {
    case locd_msg_STATE_STARTING: return "starting";
    case locd_msg_STATE_RUNNING: return "running";
    case locd_msg_STATE_STOPPED: return "stopped";
    case locd_msg_STATE_ERROR: return "error";
    case locd_msg_STATE_NO_SESSION: return "no_session";
    case locd_msg_STATE_RESTARTING: return "restarting";
    case locd_msg_STATE_FAILED: return "failed";
  }
  return "unknown(" + std::to_string(static_cast<int>(state)) + ")";
}

std::string localization_name(locd_msg_LocalizationState state) {
  switch (state) {
    case locd_msg_LOCALIZATION_UNKNOWN: return localization_state_name(LocalizationState::kUnknown);
    case locd_msg_LOCALIZATION_TRACKING: return localization_state_name(LocalizationState::kTracking);
    case locd_msg_LOCALIZATION_UNCERTAIN: return localization_state_name(LocalizationState::kUncertain);
    case locd_msg_LOCALIZATION_LOST: return localization_state_name(LocalizationState::kLost);
  }
  return "unknown(" + std::to_string(static_cast<int>(state)) + ")";
}

ServerInfo server_info_from_wire(const locd_msg_ServerInfo& m) {
  ServerInfo info;
  info.server_id = dds::to_string(m.server_id);
  info.plugins.reserve(m.plugins._length);
  for (uint32_t i = 0; i < m.plugins._length; ++i) {
    const locd_msg_PluginInfo& p = m.plugins._buffer[i];
    PluginInfo plugin;
    plugin.name = dds::to_string(p.name);
    plugin.version = dds::to_string(p.version);
    plugin.description = dds::to_string(p.description);
    for (uint32_t k = 0; k < p.consumed_kinds._length; ++k) plugin.consumes.push_back(dds::to_string(p.consumed_kinds._buffer[k]));
    info.plugins.push_back(std::move(plugin));
  }
  for (uint32_t i = 0; i < m.rejected_plugins._length; ++i) {
    info.rejected_plugins.push_back(dds::to_string(m.rejected_plugins._buffer[i]));
  }
  return info;
}

// A non-zero request id no other client is likely to pick: 64 random bits.
uint64_t fresh_request_id() {
  static std::mutex mutex;
  static std::mt19937_64 generator{(static_cast<uint64_t>(std::random_device{}()) << 32) ^ std::random_device{}() ^
                                   static_cast<uint64_t>(wall_clock_ns())};
  std::lock_guard<std::mutex> lock(mutex);
  uint64_t id = 0;
  while (id == 0) id = generator();
  return id;
}

// A user callback runs on Cyclone's listener thread, under C frames: an exception must not
// escape it. It is reported and the next sample is delivered as usual.
template <typename Callback, typename Value>
void run_callback(const Callback& callback, const Value& value, const char* which) {
  try {
    callback(value);
  } catch (const std::exception& e) {
    std::cerr << "locd client: the " << which << " callback threw: " << e.what() << "\n";
  } catch (...) {
    std::cerr << "locd client: the " << which << " callback threw a non-standard exception\n";
  }
}

template <typename Callback>
struct Subscription {
  Callback callback;
  std::string robot_filter;
};

}  // namespace

SessionStatus status_from_wire(const locd_msg_SessionStatus& m) {
  SessionStatus s;
  s.robot_id = dds::to_string(m.robot_id);
  s.server_id = dds::to_string(m.server_id);
  s.state = state_name(m.state);
  s.plugin = dds::to_string(m.plugin);
  s.request_id = m.request_id;
  s.request_ok = m.request_ok;
  s.message = dds::to_string(m.message);
  s.last_error = dds::to_string(m.last_error);
  s.received = m.received;
  s.used = m.used;
  s.dropped = m.dropped;
  s.rejected = m.rejected;
  s.updates = m.updates;
  s.last_update_ms = m.last_update_ms;
  s.initial_pose_stamp_ns = m.initial_pose_stamp_ns;
  s.failures = m.failures;
  s.lost = m.lost;
  for (uint32_t i = 0; i < m.lost_by_stream._length; ++i) {
    s.lost_by_stream.emplace_back(dds::to_string(m.lost_by_stream._buffer[i].topic), m.lost_by_stream._buffer[i].count);
  }
  s.localization = localization_name(m.localization);
  s.localization_reason = dds::to_string(m.localization_reason);
  s.held = m.held;
  s.throttled = m.throttled;
  s.waiting_for = dds::to_string(m.waiting_for);
  s.stamp_ns = m.header.stamp_ns;
  return s;
}

// Refuses options DDS could not carry, before any entity is created.
const ClientOptions& checked(const ClientOptions& o) {
  if (!o.robot_id.empty()) check_robot_id(o.robot_id);
  for (const auto& robot : o.watch) {
    if (robot != "*") check_robot_id(robot);
  }
  if (o.sensor_depth < 1 || o.sensor_depth > 10000) {
    throw std::invalid_argument("sensor_depth = " + std::to_string(o.sensor_depth) + " is out of range; allowed: 1..10000");
  }
  if (o.domain_id > 232) {
    throw std::invalid_argument("domain_id = " + std::to_string(o.domain_id) + " is out of range; allowed: 0..232");
  }
  return o;
}

// The partitions a client reads outputs in (ClientOptions::watch).
dds::Partitions watched_partitions(const ClientOptions& o) {
  if (o.watch.empty()) {
    return {o.robot_id.empty() ? topics::kAllRobotsPartition : topics::robot_partition(o.robot_id)};
  }
  dds::Partitions partitions;
  for (const auto& robot : o.watch) {
    if (robot == "*") return {topics::kAllRobotsPartition};
    partitions.push_back(topics::robot_partition(robot));
  }
  return partitions;
}

// The partition a client publishes in: its robot's (a pure watcher publishes nothing).
dds::Partitions own_partition(const ClientOptions& o) {
  return o.robot_id.empty() ? dds::Partitions{} : dds::Partitions{topics::robot_partition(o.robot_id)};
}

// The position of T among the alternatives of the variant V.
template <typename T, typename V, size_t I = 0>
constexpr size_t variant_index() {
  if constexpr (std::is_same_v<std::variant_alternative_t<I, V>, T>) {
    return I;
  } else {
    return variant_index<T, V, I + 1>();
  }
}

struct Client::Impl {
  explicit Impl(const ClientOptions& o)
      : options(checked(o)),
        participant(static_cast<dds_domainid_t>(o.domain_id)),
        odometry(writer<locd_msg_Odometry>(topics::kOdometry, dds::QosProfile::kSensor, o.sensor_depth)),
        imu(writer<locd_msg_Imu>(topics::kImu, dds::QosProfile::kSensor, o.sensor_depth)),
        scan(writer<locd_msg_LaserScan>(topics::kScan, dds::QosProfile::kSensor, o.sensor_depth)),
        cloud(writer<locd_msg_PointCloud>(topics::kCloud, dds::QosProfile::kSensor, o.sensor_depth)),
        image(writer<locd_msg_Image>(topics::kImage, dds::QosProfile::kSensor, o.sensor_depth)),
        detections(writer<locd_msg_LandmarkDetections>(topics::kDetections, dds::QosProfile::kSensor, o.sensor_depth)),
        ground_truth(writer<locd_msg_PoseEstimate>(topics::kGroundTruth, dds::QosProfile::kSensor, o.sensor_depth)),
        session_request(writer<locd_msg_SessionRequest>(topics::kSessionRequest, dds::QosProfile::kState, 8)),
        initial_pose(writer<locd_msg_InitialPose>(topics::kInitialPose, dds::QosProfile::kState, 8)),
        map_save_request(writer<locd_msg_MapSaveRequest>(topics::kMapSaveRequest, dds::QosProfile::kSensor, 8)) {
    // Readers last: their listeners call into the state above as soon as they exist.
    const dds::Partitions watched = watched_partitions(o);
    pose_reader = dds::Reader<locd_msg_PoseEstimate>(
        participant, topics::kPose, dds::QosProfile::kPose, [this](const locd_msg_PoseEstimate& m) { on_pose(m); }, 8,
        watched);
    status_reader = dds::Reader<locd_msg_SessionStatus>(
        participant, topics::kSessionStatus, dds::QosProfile::kState,
        [this](const locd_msg_SessionStatus& m) { on_status(m); }, 8, watched);
    server_reader = dds::Reader<locd_msg_ServerInfo>(participant, topics::kServerInfo, dds::QosProfile::kState,
                                                      [this](const locd_msg_ServerInfo& m) { on_server_info(m); });
    goal_reader = dds::Reader<locd_msg_ExplorationGoal>(
        participant, topics::kExplorationGoal, dds::QosProfile::kOutputState,
        [this](const locd_msg_ExplorationGoal& m) { on_exploration_goal(m); }, 8, watched);
  }

  ~Impl() {
    // Stop the listeners before the state they use goes away.
    goal_reader = {};
    server_reader = {};
    status_reader = {};
    pose_reader = {};
  }

  // A writer in the robot's partition; with DDS Security, absent where this identity may not
  // publish (an operator steers but does not feed, a monitor only reads): using it then throws
  // the refusal naming topic and partition.
  template <typename T>
  dds::Writer<T> writer(const char* topic, dds::QosProfile profile, int depth) const {
    return dds::Writer<T>::where_permitted(participant, topic, profile, depth, own_partition(options));
  }

  // Writes a sensor message numbered 1, 2, 3, ... per topic (unless the caller numbered it), so
  // the server counts what is lost in transit.
  template <typename Wire, typename Message>
  void write_numbered(const dds::Writer<Wire>& writer, const Message& m) {
    std::atomic<uint64_t>& counter = sequences[variant_index<Message, Measurement>()];
    dds::to_wire(options.robot_id, m, [&](const Wire& wire) {
      Wire numbered = wire;  // shallow: the sequences stay borrowed from `m`
      if (numbered.header.sequence_number == 0) numbered.header.sequence_number = ++counter;
      writer.write(numbered);
    });
  }
  std::array<std::atomic<uint64_t>, std::variant_size_v<Measurement>> sequences{};

  void note_written(dds_entity_t writer) {
    if (writer <= 0) return;  // absent (refused by DDS Security): its write throws
    std::lock_guard<std::mutex> lock(mutex);
    written_writers.insert(writer);
  }

  void require_robot(const char* what) const {
    if (options.robot_id.empty()) {
      throw std::logic_error(std::string(what) + " needs a robot: ClientOptions::robot_id is empty");
    }
  }

  void on_pose(const locd_msg_PoseEstimate& m) {
    PoseUpdate update;
    update.received_wall_ns = wall_clock_ns();
    update.robot_id = dds::to_string(m.robot_id);
    update.plugin = dds::to_string(m.plugin);
    update.update_ms = m.update_ms;
    try {
      update.estimate = dds::from_wire(m);
    } catch (const std::exception& e) {
      std::cerr << "locd client: dropped a pose on " << topics::kPose << " for robot '" << escaped(update.robot_id)
                << "': " << e.what() << "\n";
      return;
    }
    std::vector<Subscription<std::function<void(const PoseUpdate&)>>> subscribers;
    {
      std::lock_guard<std::mutex> lock(mutex);
      subscribers = pose_subscribers;
    }
    for (const auto& s : subscribers) {
      if (s.robot_filter.empty() || s.robot_filter == update.robot_id) run_callback(s.callback, update, "on_pose");
    }
  }

  void on_exploration_goal(const locd_msg_ExplorationGoal& m) {
    ExplorationGoalUpdate update;
    update.robot_id = dds::to_string(m.robot_id);
    update.plugin = dds::to_string(m.plugin);
    try {
      update.goal = dds::from_wire(m);
    } catch (const std::exception& e) {
      std::cerr << "locd client: dropped a goal on " << topics::kExplorationGoal << " for robot '" << escaped(update.robot_id)
                << "': " << e.what() << "\n";
      return;
    }
    std::vector<Subscription<std::function<void(const ExplorationGoalUpdate&)>>> subscribers;
    {
      std::lock_guard<std::mutex> lock(mutex);
      subscribers = goal_subscribers;
    }
    for (const auto& s : subscribers) {
      if (s.robot_filter.empty() || s.robot_filter == update.robot_id) {
        run_callback(s.callback, update, "on_exploration_goal");
      }
    }
  }

  // Registers `id` as pending, runs `send` and waits for the status answering `id`.
  std::optional<SessionStatus> await_answer(uint64_t id, const std::function<void()>& send,
                                            std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex);
    pending_requests.insert(id);
    lock.unlock();
    try {
      send();
    } catch (...) {
      lock.lock();
      pending_requests.erase(id);
      throw;
    }
    lock.lock();
    const bool answered = changed.wait_for(lock, timeout, [&] { return answers.count(id) > 0; });
    pending_requests.erase(id);
    if (!answered) return std::nullopt;
    SessionStatus answer = std::move(answers[id]);
    answers.erase(id);
    return answer;
  }

  void on_status(const locd_msg_SessionStatus& m) {
    const SessionStatus status = status_from_wire(m);
    std::vector<Subscription<std::function<void(const SessionStatus&)>>> subscribers;
    {
      std::lock_guard<std::mutex> lock(mutex);
      latest_status[status.robot_id] = status;
      // A request is answered by the first status for its robot carrying its id with an outcome
      // (a "starting" status only says the request arrived).
      if (status.robot_id == options.robot_id && pending_requests.count(status.request_id) &&
          status.state != "starting") {
        answers[status.request_id] = status;
      }
      subscribers = status_subscribers;
    }
    changed.notify_all();
    for (const auto& s : subscribers) {
      if (s.robot_filter.empty() || s.robot_filter == status.robot_id) run_callback(s.callback, status, "on_status");
    }
  }

  void on_server_info(const locd_msg_ServerInfo& m) {
    ServerInfo info = server_info_from_wire(m);
    {
      std::lock_guard<std::mutex> lock(mutex);
      servers[info.server_id] = std::move(info);
    }
    changed.notify_all();
  }

  std::optional<SessionStatus> send_request(locd_msg_SessionAction action, const std::string& plugin,
                                            const std::string& config_yaml, std::chrono::milliseconds timeout) {
    require_robot(action == locd_msg_SESSION_START ? "request_session" : "stop_session");
    auto request = std::make_unique<locd_msg_SessionRequest>();
    std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
    try {
      dds::copy_string(request->robot_id, options.robot_id);
    } catch (const std::length_error& e) {
      throw std::invalid_argument("robot_id " + std::string(e.what()));
    }
    try {
      dds::copy_string(request->plugin, plugin);
    } catch (const std::length_error& e) {
      throw std::invalid_argument("plugin name " + std::string(e.what()));
    }
    if (config_yaml.size() > topics::kMaxConfigYamlBytes) {
      throw std::invalid_argument("config_yaml is " + std::to_string(config_yaml.size()) + " bytes; " +
                                  topics::kSessionRequest + " allows at most " +
                                  std::to_string(topics::kMaxConfigYamlBytes));
    }
    dds::borrow_text(request->config_yaml, config_yaml, topics::kMaxConfigYamlBytes);
    request->action = action;
    request->request_id = fresh_request_id();
    const uint64_t id = request->request_id;
    return await_answer(
        id,
        [&] {
          note_written(session_request.handle());
          session_request.write(*request);
        },
        timeout);
  }

  ClientOptions options;
  dds::Participant participant;
  dds::Writer<locd_msg_Odometry> odometry;
  dds::Writer<locd_msg_Imu> imu;
  dds::Writer<locd_msg_LaserScan> scan;
  dds::Writer<locd_msg_PointCloud> cloud;
  dds::Writer<locd_msg_Image> image;
  dds::Writer<locd_msg_LandmarkDetections> detections;
  dds::Writer<locd_msg_PoseEstimate> ground_truth;
  dds::Writer<locd_msg_SessionRequest> session_request;
  dds::Writer<locd_msg_InitialPose> initial_pose;
  dds::Writer<locd_msg_MapSaveRequest> map_save_request;

  mutable std::mutex mutex;
  std::condition_variable changed;
  std::map<std::string, SessionStatus> latest_status;  // by robot_id
  std::map<std::string, ServerInfo> servers;           // by server_id
  std::set<uint64_t> pending_requests;
  std::set<dds_entity_t> written_writers;  // for wait_for_delivery
  std::map<uint64_t, SessionStatus> answers;  // by request_id, for pending requests only
  std::vector<Subscription<std::function<void(const PoseUpdate&)>>> pose_subscribers;
  std::vector<Subscription<std::function<void(const SessionStatus&)>>> status_subscribers;
  std::vector<Subscription<std::function<void(const ExplorationGoalUpdate&)>>> goal_subscribers;

  dds::Reader<locd_msg_PoseEstimate> pose_reader;
  dds::Reader<locd_msg_SessionStatus> status_reader;
  dds::Reader<locd_msg_ServerInfo> server_reader;
  dds::Reader<locd_msg_ExplorationGoal> goal_reader;
};

Client::Client(const ClientOptions& options) : impl_(std::make_unique<Impl>(options)) {}
Client::~Client() = default;

const std::string& Client::robot_id() const { return impl_->options.robot_id; }

void Client::publish(const Odometry& m) {
  impl_->require_robot("publish(Odometry)");
  impl_->note_written(impl_->odometry.handle());
  impl_->write_numbered(impl_->odometry, m);
}
void Client::publish(const Imu& m) {
  impl_->require_robot("publish(Imu)");
  impl_->note_written(impl_->imu.handle());
  impl_->write_numbered(impl_->imu, m);
}
void Client::publish(const LaserScan& m) {
  impl_->require_robot("publish(LaserScan)");
  impl_->note_written(impl_->scan.handle());
  impl_->write_numbered(impl_->scan, m);
}
void Client::publish(const PointCloud& m) {
  impl_->require_robot("publish(PointCloud)");
  impl_->note_written(impl_->cloud.handle());
  impl_->write_numbered(impl_->cloud, m);
}
void Client::publish(const Image& m) {
  impl_->require_robot("publish(Image)");
  if (m.channels != 1 && m.channels != 3) {
    throw std::invalid_argument("image channels = " + std::to_string(m.channels) + "; allowed: 1 (mono8), 3 (bgr8)");
  }
  if (m.width < 0 || m.height < 0 ||
      m.data.size() != static_cast<size_t>(m.width) * static_cast<size_t>(m.height) * static_cast<size_t>(m.channels)) {
    throw std::invalid_argument("image data is " + std::to_string(m.data.size()) + " bytes; width * height * channels = " +
                                std::to_string(static_cast<long long>(m.width) * m.height * m.channels));
  }
  impl_->note_written(impl_->image.handle());
  impl_->write_numbered(impl_->image, m);
}
void Client::publish(const LandmarkDetections& m) {
  impl_->require_robot("publish(LandmarkDetections)");
  impl_->note_written(impl_->detections.handle());
  impl_->write_numbered(impl_->detections, m);
}
void Client::publish_ground_truth(const PoseEstimate& truth) {
  impl_->require_robot("publish_ground_truth");
  impl_->note_written(impl_->ground_truth.handle());
  dds::write(impl_->ground_truth, impl_->options.robot_id, truth, "ground_truth");
}

std::optional<SessionStatus> Client::request_session(const std::string& plugin, const std::string& config_yaml,
                                                     std::chrono::milliseconds timeout) {
  return impl_->send_request(locd_msg_SESSION_START, plugin, config_yaml, timeout);
}

std::optional<SessionStatus> Client::stop_session(std::chrono::milliseconds timeout) {
  return impl_->send_request(locd_msg_SESSION_STOP, "", "", timeout);
}

void Client::set_initial_pose(const PoseEstimate& pose) {
  impl_->require_robot("set_initial_pose");
  impl_->note_written(impl_->initial_pose.handle());
  dds::write(impl_->initial_pose, impl_->options.robot_id, pose);
}

std::optional<SessionStatus> Client::set_initial_pose(const PoseEstimate& pose, std::chrono::milliseconds timeout) {
  impl_->require_robot("set_initial_pose");
  if (pose.header.stamp_ns == 0) {
    throw std::invalid_argument("set_initial_pose: the pose is stamped 0; stamp it (e.g. with the robot's clock) so "
                                "its acknowledgement can be told from an earlier one");
  }
  const std::string& robot = impl_->options.robot_id;
  std::unique_lock<std::mutex> lock(impl_->mutex);
  const auto before = impl_->latest_status.find(robot);
  const uint64_t rejected_before = before == impl_->latest_status.end() ? 0 : before->second.rejected;
  lock.unlock();
  set_initial_pose(pose);
  lock.lock();
  const auto answered = [&] {
    const auto it = impl_->latest_status.find(robot);
    if (it == impl_->latest_status.end()) return false;
    const SessionStatus& s = it->second;
    return s.initial_pose_stamp_ns == pose.header.stamp_ns ||
           (s.rejected > rejected_before && s.last_error.rfind("initial pose rejected", 0) == 0);
  };
  if (!impl_->changed.wait_for(lock, timeout, answered)) return std::nullopt;
  return impl_->latest_status.at(robot);
}

bool Client::wait_for_server(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  return impl_->changed.wait_for(lock, timeout, [&] { return !impl_->servers.empty(); });
}

bool Client::wait_for_delivery(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::set<dds_entity_t> writers;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    writers = impl_->written_writers;
  }
  for (const dds_entity_t writer : writers) {
    dds_publication_matched_status_t matched{};
    for (;;) {
      dds::check(dds_get_publication_matched_status(writer, &matched), "publication matched status");
      if (matched.current_count > 0) break;
      if (std::chrono::steady_clock::now() >= deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - std::chrono::steady_clock::now());
    const dds_return_t rc = dds_wait_for_acks(writer, std::max<int64_t>(0, left.count()));
    if (rc == DDS_RETCODE_TIMEOUT) return false;
    dds::check(rc, "wait for acknowledgments");
  }
  return true;
}

void Client::on_pose(std::function<void(const PoseUpdate&)> callback, const std::string& robot_filter) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->pose_subscribers.push_back({std::move(callback), robot_filter});
}

void Client::on_status(std::function<void(const SessionStatus&)> callback, const std::string& robot_filter) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->status_subscribers.push_back({std::move(callback), robot_filter});
}

void Client::on_exploration_goal(std::function<void(const ExplorationGoalUpdate&)> callback,
                                 const std::string& robot_filter) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->goal_subscribers.push_back({std::move(callback), robot_filter});
}

std::optional<SessionStatus> Client::save_map(std::chrono::milliseconds timeout) {
  impl_->require_robot("save_map");
  locd_msg_MapSaveRequest request;
  std::memset(&request, 0, sizeof request);
  dds::copy_string(request.robot_id, impl_->options.robot_id);
  request.request_id = fresh_request_id();
  // The request topic is volatile: written before a server's reader matched, it would be lost.
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (impl_->map_save_request.matched() == 0) {
    if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  timeout = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
  return impl_->await_answer(
      request.request_id,
      [&] {
        impl_->note_written(impl_->map_save_request.handle());
        impl_->map_save_request.write(request);
      },
      timeout);
}

std::vector<SessionStatus> Client::statuses() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  std::vector<SessionStatus> out;
  out.reserve(impl_->latest_status.size());
  for (const auto& [robot, status] : impl_->latest_status) out.push_back(status);
  return out;
}

std::vector<ServerInfo> Client::servers() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  std::vector<ServerInfo> out;
  out.reserve(impl_->servers.size());
  for (const auto& [id, info] : impl_->servers) out.push_back(info);
  return out;
}

}  // namespace locd
