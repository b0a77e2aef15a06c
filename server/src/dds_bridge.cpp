#include "locd/server/dds_bridge.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <optional>
#include <type_traits>
#include <vector>

#include "locd/dds/convert.hpp"
#include "locd/dds/topics.hpp"
#include "locd/sdk/robot_id.hpp"
#include "locd/sdk/text.hpp"
#include "locd/sdk/validate.hpp"
#include "locd/server/server.hpp"
#include "locd/server/session.hpp"

namespace locd::server {
namespace {

constexpr int kSensorReaderDepth = 32;

// Copies into a bounded IDL string, cutting what does not fit (status texts may be long).
template <size_t N>
void copy_truncated(char (&dst)[N], const std::string& src) {
  const size_t n = std::min(src.size(), N - 1);
  std::memcpy(dst, src.data(), n);
  dst[n] = '\0';
}

locd_msg_SessionState wire_state(SessionState state) {
  switch (state) {
    case SessionState::kStarting: return locd_msg_STATE_STARTING;
    case SessionState::kRunning: return locd_msg_STATE_RUNNING;
    case SessionState::kStopped: return locd_msg_STATE_STOPPED;
    case SessionState::kError: return locd_msg_STATE_ERROR;
    case SessionState::kNoSession: return locd_msg_STATE_NO_SESSION;
    case SessionState::kRestarting: return locd_msg_STATE_RESTARTING;
    case SessionState::kFailed: return locd_msg_STATE_FAILED;
  }
  return locd_msg_STATE_ERROR;
}

locd_msg_LocalizationState wire_localization(LocalizationState state) {
  switch (state) {
    case LocalizationState::kUnknown: return locd_msg_LOCALIZATION_UNKNOWN;
    case LocalizationState::kTracking: return locd_msg_LOCALIZATION_TRACKING;
    case LocalizationState::kUncertain: return locd_msg_LOCALIZATION_UNCERTAIN;
    case LocalizationState::kLost: return locd_msg_LOCALIZATION_LOST;
  }
  return locd_msg_LOCALIZATION_UNKNOWN;
}

Odometry convert(const locd_msg_Odometry& m, const Limits&) { return dds::from_wire(m); }
Imu convert(const locd_msg_Imu& m, const Limits&) { return dds::from_wire(m); }
template <typename Wire>
auto convert(const Wire& m, const Limits& limits) -> decltype(dds::from_wire(m, limits)) {
  return dds::from_wire(m, limits);
}

}  // namespace

// One robot's output writers at one claim's ownership strength, in its partition robot.<robot_id>.
// Pose and diagnostics are made with them; maps, grids and goals when the robot's plugin first
// publishes one.
struct DdsBridge::OwnedWriters {
  template <typename T>
  struct Lazy {
    const dds::Writer<T>& get(std::mutex& mutex, const dds::Participant& p, const char* topic,
                              const dds::Partitions& partitions, int32_t strength) {
      std::lock_guard<std::mutex> lock(mutex);
      if (!writer) {
        writer = std::make_unique<dds::Writer<T>>(p, topic, dds::QosProfile::kOutputState, 8, partitions, strength);
      }
      return *writer;
    }
    std::unique_ptr<dds::Writer<T>> writer;
  };

  OwnedWriters(const dds::Participant& p, const dds::Partitions& partitions, int32_t strength)
      : partitions(partitions),
        strength(strength),
        pose(p, topics::kPose, dds::QosProfile::kPose, 8, partitions, strength),
        diagnostics(p, topics::kDiagnostics, dds::QosProfile::kOutput, 8, partitions, strength) {}

  const dds::Partitions partitions;
  const int32_t strength;
  dds::Writer<locd_msg_PoseEstimate> pose;
  dds::Writer<locd_msg_Diagnostics> diagnostics;
  std::mutex mutex;  // guards the lazy writers' creation
  Lazy<locd_msg_GridMap> grid;
  Lazy<locd_msg_PointCloudMap> map_cloud;
  Lazy<locd_msg_LandmarkMap> landmark_map;
  Lazy<locd_msg_ExplorationGoal> exploration_goal;
};

// One robot's writers, in its partition: the status (shared), and the outputs while claimed.
struct DdsBridge::RobotWriters {
  RobotWriters(const dds::Participant& p, const std::string& robot_id)
      : partitions{topics::robot_partition(robot_id)},
        status(p, topics::kSessionStatus, dds::QosProfile::kState, 8, partitions) {}

  dds::Partitions partitions;
  dds::Writer<locd_msg_SessionStatus> status;
  std::mutex mutex;                     // guards `owned`
  std::shared_ptr<OwnedWriters> owned;  // while this server claims the robot
  uint64_t last_use = 0;                // under DdsBridge::writers_mutex_
};

struct DdsBridge::Readers {
  dds::Reader<locd_msg_Odometry> odometry;
  dds::Reader<locd_msg_Imu> imu;
  dds::Reader<locd_msg_LaserScan> scan;
  dds::Reader<locd_msg_PointCloud> cloud;
  dds::Reader<locd_msg_Image> image;
  dds::Reader<locd_msg_LandmarkDetections> detections;
  dds::Reader<locd_msg_SessionRequest> session_request;
  dds::Reader<locd_msg_InitialPose> initial_pose;
  dds::Reader<locd_msg_MapSaveRequest> map_save_request;
  // The fleet's other servers.
  dds::Reader<locd_msg_ServerInfo> servers;
  dds::Reader<locd_msg_ServingClaim> claims;
  dds::Reader<locd_msg_ResumeState> resume_states;
};

DdsBridge::DdsBridge(int domain_id, std::string server_id, const Limits& limits, Logger& logger, size_t max_robots)
    : server_id_(std::move(server_id)), limits_(limits), logger_(logger), max_robots_(std::max<size_t>(1, max_robots)),
      participant_(static_cast<dds_domainid_t>(domain_id)),
      server_info_(participant_, topics::kServerInfo, dds::QosProfile::kState),
      claims_(participant_, topics::kServingClaim, dds::QosProfile::kState),
      resume_states_(participant_, topics::kResumeState, dds::QosProfile::kState),
      deleter_([this] { deleter_loop(); }) {}

DdsBridge::~DdsBridge() {
  disconnect();
  {
    std::lock_guard<std::mutex> lock(deleter_mutex_);
    deleter_stopping_ = true;
  }
  deleter_wakes_.notify_all();
  deleter_.join();
}

void DdsBridge::delete_later(std::shared_ptr<void> writers) {
  if (!writers) return;
  {
    std::lock_guard<std::mutex> lock(deleter_mutex_);
    to_delete_.push_back(std::move(writers));
  }
  deleter_wakes_.notify_all();
}

void DdsBridge::deleter_loop() {
  std::unique_lock<std::mutex> lock(deleter_mutex_);
  for (;;) {
    deleter_wakes_.wait(lock, [this] { return deleter_stopping_ || !to_delete_.empty(); });
    std::vector<std::shared_ptr<void>> batch;
    batch.swap(to_delete_);
    lock.unlock();
    batch.clear();  // the writers go here (the last reference, unless one is still being written to)
    lock.lock();
    if (deleter_stopping_ && to_delete_.empty()) return;
  }
}

std::shared_ptr<DdsBridge::RobotWriters> DdsBridge::writers_for(const std::string& robot_id) {
  std::lock_guard<std::mutex> lock(writers_mutex_);
  auto& slot = robot_writers_[robot_id];
  if (!slot) {
    if (robot_writers_.size() > max_robots_) {
      // Release the robot written to least recently (its transient-local data goes with it).
      auto oldest = robot_writers_.end();
      for (auto it = robot_writers_.begin(); it != robot_writers_.end(); ++it) {
        if (it->second && (oldest == robot_writers_.end() || it->second->last_use < oldest->second->last_use)) oldest = it;
      }
      if (oldest != robot_writers_.end()) {
        delete_later(oldest->second);
        robot_writers_.erase(oldest);
      }
    }
    slot = std::make_shared<RobotWriters>(participant_, robot_id);
  }
  slot->last_use = ++use_counter_;
  return slot;
}

namespace {

// The robot's inputs, numbered for RobotWriterPresence.
enum Input : unsigned {
  kOdometryInput, kImuInput, kScanInput, kCloudInput, kImageInput, kDetectionsInput,
  kSessionRequestInput, kInitialPoseInput, kMapSaveRequestInput,
};

// Every per-robot reader of the server: in every robot's partition, robot scoped. A sample from a
// writer outside its robot's partition is refused and reported to the writer's own robot, if the
// writer has one; a robot id that is not allowed is refused before anything is kept for it.
// Samples from the robot's own partition mark the robot present on `input`; its instance losing
// every writer marks it absent there (session ownership: Server::on_robot_writers).
// `handle(robot_id, sample)`, or `handle(robot_id, sample, writer_participant)` where the writer's
// participant matters (rate limits of session requests; only those pay for the copy).
template <typename Wire, typename Handle>
dds::Reader<Wire> robot_reader(const dds::Participant& participant, const char* topic, Input input,
                               dds::QosProfile profile, Server& server, RobotWriterPresence& presence, Handle&& handle,
                               int depth = 8) {
  // The robot id allowed, and the robot marked present on `input`.
  auto accept = [&server, &presence, topic, input](const Wire& sample) -> std::optional<std::string> {
    std::string robot_id = dds::to_string(sample.robot_id);
    if (std::string error = robot_id_error(robot_id); !error.empty()) {
      server.on_invalid_robot_id(topic, error);
      return std::nullopt;
    }
    if (const auto changed = presence.update(robot_id, input, true)) server.on_robot_writers(robot_id, *changed);
    return robot_id;
  };
  auto callback = [&] {
    if constexpr (std::is_invocable_v<Handle, const std::string&, const Wire&, const std::string&>) {
      return typename dds::Reader<Wire>::SourcedCallback(
          [accept, handle = std::forward<Handle>(handle)](const Wire& sample, const std::string& writer_participant) {
            if (const auto robot_id = accept(sample)) handle(*robot_id, sample, writer_participant);
          });
    } else {
      return typename dds::Reader<Wire>::Callback([accept, handle = std::forward<Handle>(handle)](const Wire& sample) {
        if (const auto robot_id = accept(sample)) handle(*robot_id, sample);
      });
    }
  };
  return dds::Reader<Wire>(
      participant, topic, profile, callback(),
      depth, {topics::kAllRobotsPartition},
      [&server, topic](const Wire& sample, const dds::Partitions& writer_partitions) {
        std::string writer_robot;
        std::string partitions;
        for (const auto& p : writer_partitions) {
          partitions += (partitions.empty() ? "" : ", ") + p;
          const std::string prefix = topics::kRobotPartitionPrefix;
          if (writer_robot.empty() && p.rfind(prefix, 0) == 0) writer_robot = p.substr(prefix.size());
        }
        const std::string error = "a sample for robot '" + escaped(dds::to_string(sample.robot_id)) +
                                  "' was published in partition [" + escaped(partitions) +
                                  "]; a robot publishes only in its own partition " + topics::kRobotPartitionPrefix +
                                  "<robot_id>";
        if (robot_id_error(writer_robot).empty()) {
          server.on_bad_input(writer_robot, topic, error);
        } else {
          server.on_invalid_robot_id(topic, error);
        }
      },
      [&server, &presence, input](const Wire& key, dds::InstanceGone) {
        const std::string robot_id = dds::to_string(key.robot_id);
        if (!robot_id_error(robot_id).empty()) return;
        if (const auto changed = presence.update(robot_id, input, false)) server.on_robot_writers(robot_id, *changed);
      });
}

template <typename Wire>
dds::Reader<Wire> sensor_reader(const dds::Participant& participant, const char* topic, Input input, Server& server,
                                RobotWriterPresence& presence, const Limits& limits) {
  return robot_reader<Wire>(
      participant, topic, input, dds::QosProfile::kSensor, server, presence,
      [&server, &limits, topic](const std::string& robot_id, const Wire& sample) {
        try {
          server.on_measurement(robot_id, Measurement(convert(sample, limits)));
        } catch (const std::exception& e) {
          server.on_bad_input(robot_id, topic, e.what());
        }
      },
      kSensorReaderDepth);
}

}  // namespace

void DdsBridge::connect(Server& server) {
  auto readers = std::make_unique<Readers>();
  auto& p = participant_;
  readers->odometry = sensor_reader<locd_msg_Odometry>(p, topics::kOdometry, kOdometryInput, server, presence_, limits_);
  readers->imu = sensor_reader<locd_msg_Imu>(p, topics::kImu, kImuInput, server, presence_, limits_);
  readers->scan = sensor_reader<locd_msg_LaserScan>(p, topics::kScan, kScanInput, server, presence_, limits_);
  readers->cloud = sensor_reader<locd_msg_PointCloud>(p, topics::kCloud, kCloudInput, server, presence_, limits_);
  readers->image = sensor_reader<locd_msg_Image>(p, topics::kImage, kImageInput, server, presence_, limits_);
  readers->detections =
      sensor_reader<locd_msg_LandmarkDetections>(p, topics::kDetections, kDetectionsInput, server, presence_, limits_);
  Logger* logger = &logger_;
  readers->session_request = robot_reader<locd_msg_SessionRequest>(
      participant_, topics::kSessionRequest, kSessionRequestInput, dds::QosProfile::kState, server, presence_,
      [&server, logger](const std::string& robot_id, const locd_msg_SessionRequest& sample,
                        const std::string& writer_participant) {
        SessionRequestMessage request;
        request.robot_id = robot_id;
        request.source = writer_participant;
        request.request_id = sample.request_id;
        request.stop = sample.action == locd_msg_SESSION_STOP;
        request.plugin = dds::to_string(sample.plugin);
        request.config_yaml = dds::to_string(sample.config_yaml);
        try {
          server.on_session_request(std::move(request));
        } catch (const std::exception& e) {
          logger->log(LogLevel::kError, "server", std::string("session request not handled: ") + e.what());
        }
      });
  readers->initial_pose = robot_reader<locd_msg_InitialPose>(
      participant_, topics::kInitialPose, kInitialPoseInput, dds::QosProfile::kState, server, presence_,
      [&server](const std::string& robot_id, const locd_msg_InitialPose& sample) {
        try {
          server.on_initial_pose(robot_id, dds::from_wire(sample));
        } catch (const std::exception& e) {
          server.on_bad_input(robot_id, topics::kInitialPose, e.what());
        }
      });
  readers->map_save_request = robot_reader<locd_msg_MapSaveRequest>(
      participant_, topics::kMapSaveRequest, kMapSaveRequestInput, dds::QosProfile::kSensor, server, presence_,
      [&server](const std::string& robot_id, const locd_msg_MapSaveRequest& sample) {
        server.on_map_save_request(robot_id, sample.request_id);
      });
  // The fleet: servers come and stay alive (ServerInfo, a heartbeat every 100 ms), go (silent for
  // 500 ms, Server::rebalance; or their writer deleted on a clean stop), claim robots
  // and withdraw claims (disposed, or gone with their server), and share resume states.
  readers->servers = dds::Reader<locd_msg_ServerInfo>(
      participant_, topics::kServerInfo, dds::QosProfile::kState,
      [&server](const locd_msg_ServerInfo& m) {
        server.on_server_alive({dds::to_string(m.server_id), m.weight > 0.0 ? m.weight : 1.0,
                                dds::to_string(m.server_group)});
      },
      8, {}, nullptr,
      [&server](const locd_msg_ServerInfo& key, dds::InstanceGone) { server.on_server_gone(dds::to_string(key.server_id)); });
  readers->claims = dds::Reader<locd_msg_ServingClaim>(
      participant_, topics::kServingClaim, dds::QosProfile::kState,
      [&server](const locd_msg_ServingClaim& m) {
        server.on_claim(dds::to_string(m.robot_id), dds::to_string(m.server_id), true, m.since_ns, m.strength);
      },
      8, {}, nullptr,
      [&server](const locd_msg_ServingClaim& key, dds::InstanceGone) {
        server.on_claim(dds::to_string(key.robot_id), dds::to_string(key.server_id), false);
      });
  readers->resume_states = dds::Reader<locd_msg_ResumeState>(
      participant_, topics::kResumeState, dds::QosProfile::kState, [&server](const locd_msg_ResumeState& m) {
        ResumeState state;
        state.server = dds::to_string(m.server_id);
        state.plugin = dds::to_string(m.plugin);
        state.request_id = m.request_id;
        state.failed = m.failed;
        state.estimate.header = {m.header.stamp_ns, "map"};
        state.estimate.pose = dds::from_wire(m.pose);
        for (int i = 0; i < 36; ++i) state.estimate.covariance(i / 6, i % 6) = m.covariance[i];
        if (m.has_map_from_odom) state.map_from_odom = dds::from_wire(m.map_from_odom);
        const std::string robot_id = dds::to_string(m.robot_id);
        if (!robot_id_error(robot_id).empty()) return;
        try {
          validate(state.estimate);  // another server is trusted no more than the network
        } catch (const std::exception&) {
          return;
        }
        server.on_peer_resume_state(robot_id, state.server, state);
      });
  readers_ = std::move(readers);
}

void DdsBridge::disconnect() { readers_.reset(); }

void DdsBridge::publish_status(const SessionStatusReport& s) {
  auto wire = std::make_unique<locd_msg_SessionStatus>();
  std::memset(wire.get(), 0, sizeof(locd_msg_SessionStatus));
  copy_truncated(wire->robot_id, s.robot_id);
  wire->header.stamp_ns = s.stamp_ns;
  copy_truncated(wire->header.frame_id, "");
  copy_truncated(wire->server_id, server_id_);
  wire->state = wire_state(s.state);
  copy_truncated(wire->plugin, s.plugin);
  wire->request_id = s.request_id;
  wire->request_ok = s.request_ok;
  copy_truncated(wire->message, s.message);
  copy_truncated(wire->last_error, s.last_error);
  wire->received = s.counters.received;
  wire->used = s.counters.used;
  wire->dropped = s.counters.dropped;
  wire->rejected = s.counters.rejected;
  wire->updates = s.counters.updates;
  wire->last_update_ms = s.counters.last_update_ms;
  wire->initial_pose_stamp_ns = s.initial_pose_stamp_ns;
  wire->failures = s.failures;
  wire->localization = wire_localization(s.localization.state);
  copy_truncated(wire->localization_reason, s.localization.reason);
  wire->held = s.counters.held;
  wire->throttled = s.counters.throttled;
  copy_truncated(wire->waiting_for, s.waiting_for);
  wire->lost = s.counters.lost;
  std::array<locd_msg_StreamCount, 6> lost{};
  uint32_t streams = 0;
  for (size_t kind = 0; kind < s.counters.lost_by_kind.size(); ++kind) {
    if (s.counters.lost_by_kind[kind] == 0) continue;
    copy_truncated(lost[streams].topic, topic_of(static_cast<MeasurementKind>(1u << kind)));
    lost[streams].count = s.counters.lost_by_kind[kind];
    ++streams;
  }
  wire->lost_by_stream._length = wire->lost_by_stream._maximum = streams;
  wire->lost_by_stream._buffer = lost.data();
  wire->lost_by_stream._release = false;
  writers_for(s.robot_id)->status.write(*wire);
}

std::shared_ptr<DdsBridge::OwnedWriters> DdsBridge::owned_writers_for(const std::string& robot_id) {
  int32_t strength = 0;
  {
    std::lock_guard<std::mutex> lock(fleet_mutex_);
    const auto claim = claimed_.find(robot_id);
    if (claim == claimed_.end()) {
      ++outputs_unclaimed_;
      return nullptr;
    }
    strength = claim->second.strength;
  }
  const auto writers = writers_for(robot_id);
  std::lock_guard<std::mutex> lock(writers->mutex);
  if (!writers->owned || writers->owned->strength != strength) {
    delete_later(std::move(writers->owned));
    writers->owned = std::make_shared<OwnedWriters>(participant_, writers->partitions, strength);
  }
  return writers->owned;
}

void DdsBridge::publish_outputs(const std::string& robot_id, const std::string& plugin, const Header& header,
                                const UpdateResult& result, double update_ms) {
  // Not claimed (any more): the server stopped serving the robot, or handed it to another
  // server, while this update was with the plugin. Another server's outputs are the robot's now.
  const auto writers = owned_writers_for(robot_id);
  if (!writers) return;
  auto& w = *writers;
  const auto& p = participant_;
  const auto& at = w.partitions;
  if (result.estimate) dds::write(w.pose, robot_id, *result.estimate, plugin, update_ms);
  if (!result.diagnostics.empty()) dds::write(w.diagnostics, robot_id, header, plugin, result.diagnostics);
  if (result.grid) dds::write(w.grid.get(w.mutex, p, topics::kGrid, at, w.strength), robot_id, header, *result.grid);
  if (result.map_cloud) {
    dds::write(w.map_cloud.get(w.mutex, p, topics::kMapCloud, at, w.strength), robot_id, header, *result.map_cloud);
  }
  if (result.landmark_map) {
    dds::write(w.landmark_map.get(w.mutex, p, topics::kLandmarkMap, at, w.strength), robot_id, header,
               *result.landmark_map);
  }
  if (result.exploration_goal) {
    dds::write(w.exploration_goal.get(w.mutex, p, topics::kExplorationGoal, at, w.strength), robot_id,
               *result.exploration_goal, plugin);
  }
}

void DdsBridge::publish_claim(const std::string& robot_id, bool serving, int32_t strength) {
  locd_msg_ServingClaim claim;
  std::memset(&claim, 0, sizeof claim);
  copy_truncated(claim.robot_id, robot_id);
  copy_truncated(claim.server_id, server_id_);
  claim.since_ns = wall_clock_ns();
  claim.strength = strength;
  {
    std::lock_guard<std::mutex> lock(fleet_mutex_);
    if (serving) {
      claims_.write(claim);
      claimed_[robot_id] = {claim.since_ns, strength};
    } else {
      claimed_.erase(robot_id);
      dds::check(dds_dispose(claims_.handle(), &claim), "withdraw a claim");
    }
  }
  if (serving) {
    // Made now, so the robot's readers have matched them by the first pose.
    owned_writers_for(robot_id);
    return;
  }
  // Deleted (on the deleter thread): DDS unregisters the robot's instances, so another server's
  // outputs reach it.
  std::shared_ptr<RobotWriters> writers;
  {
    std::lock_guard<std::mutex> lock(writers_mutex_);
    const auto it = robot_writers_.find(robot_id);
    if (it != robot_writers_.end()) writers = it->second;
  }
  if (!writers) return;
  std::lock_guard<std::mutex> lock(writers->mutex);
  delete_later(std::move(writers->owned));
}

void DdsBridge::republish_claims() {
  std::lock_guard<std::mutex> lock(fleet_mutex_);
  for (const auto& [robot_id, held] : claimed_) {
    locd_msg_ServingClaim claim;
    std::memset(&claim, 0, sizeof claim);
    copy_truncated(claim.robot_id, robot_id);
    copy_truncated(claim.server_id, server_id_);
    claim.since_ns = held.since_ns;
    claim.strength = held.strength;
    claims_.write(claim);
  }
}

void DdsBridge::publish_resume_state(const std::string& robot_id, const ResumeState& state) {
  locd_msg_ResumeState wire;
  std::memset(&wire, 0, sizeof wire);
  copy_truncated(wire.robot_id, robot_id);
  copy_truncated(wire.server_id, server_id_);
  wire.header.stamp_ns = state.estimate.header.stamp_ns;
  copy_truncated(wire.header.frame_id, "map");
  dds::to_wire(state.estimate.pose, wire.pose);
  for (int i = 0; i < 36; ++i) wire.covariance[i] = state.estimate.covariance(i / 6, i % 6);
  wire.has_map_from_odom = state.map_from_odom.has_value();
  if (state.map_from_odom) dds::to_wire(*state.map_from_odom, wire.map_from_odom);
  copy_truncated(wire.plugin, state.plugin);
  wire.request_id = state.request_id;
  wire.failed = state.failed;
  std::lock_guard<std::mutex> lock(fleet_mutex_);
  resume_states_.write(wire);
}

void DdsBridge::publish_server_info(const ServerInfoReport& info) {
  locd_msg_ServerInfo wire;
  std::memset(&wire, 0, sizeof wire);
  copy_truncated(wire.server_id, info.server_id);
  wire.started_ns = info.started_ns;
  wire.weight = info.weight;
  copy_truncated(wire.server_group, info.server_group);

  constexpr size_t kMaxPlugins = 256, kMaxRejected = 64, kMaxKinds = 16;
  std::vector<locd_msg_PluginInfo> plugins(std::min(info.plugins.size(), kMaxPlugins));
  std::vector<std::vector<std::array<char, 33>>> consumes(plugins.size());
  for (size_t i = 0; i < plugins.size(); ++i) {
    const auto& p = info.plugins[i];
    std::memset(&plugins[i], 0, sizeof plugins[i]);
    copy_truncated(plugins[i].name, p.name);
    copy_truncated(plugins[i].version, p.version);
    copy_truncated(plugins[i].description, p.description);
    for (size_t k = 0; k < std::min(p.consumes.size(), kMaxKinds); ++k) {
      std::array<char, 33> kind{};
      std::strncpy(kind.data(), p.consumes[k].c_str(), kind.size() - 1);
      consumes[i].push_back(kind);
    }
    plugins[i].consumed_kinds._length = plugins[i].consumed_kinds._maximum = static_cast<uint32_t>(consumes[i].size());
    plugins[i].consumed_kinds._buffer = reinterpret_cast<char(*)[33]>(consumes[i].data());
    plugins[i].consumed_kinds._release = false;
  }
  wire.plugins._length = wire.plugins._maximum = static_cast<uint32_t>(plugins.size());
  wire.plugins._buffer = plugins.data();
  wire.plugins._release = false;

  std::vector<std::array<char, 257>> rejected(std::min(info.rejected_plugins.size(), kMaxRejected));
  for (size_t i = 0; i < rejected.size(); ++i) {
    rejected[i].fill('\0');
    std::strncpy(rejected[i].data(), info.rejected_plugins[i].c_str(), rejected[i].size() - 1);
  }
  wire.rejected_plugins._length = wire.rejected_plugins._maximum = static_cast<uint32_t>(rejected.size());
  wire.rejected_plugins._buffer = reinterpret_cast<char(*)[257]>(rejected.data());
  wire.rejected_plugins._release = false;
  server_info_.write(wire);
}

}  // namespace locd::server
