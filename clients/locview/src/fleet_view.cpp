#include "fleet_view.hpp"

#include <functional>
#include <iostream>
#include <map>
#include <mutex>

#include "foxglove.hpp"
#include "locd/dds/dds.hpp"
#include "locd/sdk/robot_id.hpp"
#include "locd/sdk/text.hpp"

namespace locd::view {
namespace {

enum Slot { kPose, kCovariance, kTransforms, kParticles, kDiagnostics, kScan, kCloud, kLandmarks, kMapCloud, kGoal,
            kStatus, kTruth, kSlots };

struct SlotInfo {
  const char* name;
  const char* schema;
  bool latched;
};

const SlotInfo kSlotInfo[kSlots] = {
    {"pose", "foxglove.PoseInFrame", false},          {"pose_covariance", "foxglove.SceneUpdate", false},
    {"transforms", "foxglove.FrameTransform", false}, {"particles", "foxglove.PosesInFrame", false},
    {"diagnostics", "locd.DiagnosticValues", false},  {"scan", "foxglove.PointCloud", false},
    {"cloud", "foxglove.PointCloud", false},          {"landmark_map", "foxglove.SceneUpdate", true},
    {"map_cloud", "foxglove.PointCloud", true},       {"exploration_goal", "foxglove.PoseInFrame", true},
    {"status", "locd.SessionStatus", true},           {"ground_truth", "foxglove.PoseInFrame", false},
};

uint64_t time_of(int64_t stamp_ns) { return stamp_ns > 0 ? static_cast<uint64_t>(stamp_ns) : 0; }

}  // namespace

struct FleetView::Impl {
  struct Robot {
    uint32_t channel[kSlots] = {};
    std::map<std::string, uint32_t> grids;  // layer -> channel
  };

  FoxgloveServer& server;
  ViewOptions options;
  mutable std::mutex mutex;
  std::map<std::string, Robot> robots;
  bool warned_full = false;
  dds::Participant participant;
  dds::Partitions partitions;
  dds::Reader<locd_msg_PoseEstimate> pose, truth;
  dds::Reader<locd_msg_Diagnostics> diagnostics;
  dds::Reader<locd_msg_LaserScan> scan;
  dds::Reader<locd_msg_PointCloud> cloud;
  dds::Reader<locd_msg_LandmarkMap> landmarks;
  dds::Reader<locd_msg_GridMap> grid;
  dds::Reader<locd_msg_PointCloudMap> map_cloud;
  dds::Reader<locd_msg_ExplorationGoal> goal;
  dds::Reader<locd_msg_SessionStatus> status;

  Impl(FoxgloveServer& s, const ViewOptions& o) : server(s), options(o), participant(o.domain_id) {
    for (const auto& r : o.robots) {
      check_robot_id(r);
      partitions.push_back(topics::robot_partition(r));
    }
    if (partitions.empty()) partitions.push_back(topics::kAllRobotsPartition);
    using dds::QosProfile;
    pose = reader<locd_msg_PoseEstimate>(topics::kPose, QosProfile::kPose, [this](const locd_msg_PoseEstimate& m) {
      const Robot* r = robot(m.robot_id);
      if (!r) return;
      const uint64_t t = time_of(m.header.stamp_ns);
      emit(*r, kPose, t, [&] { return pose_in_frame(m.header, m.pose); });
      emit(*r, kCovariance, t, [&] { return covariance_ellipse(m); });
      emit(*r, kTransforms, t, [&] { return base_transform(m); });
    });
    truth = reader<locd_msg_PoseEstimate>(topics::kGroundTruth, QosProfile::kSensor, [this](const locd_msg_PoseEstimate& m) {
      if (const Robot* r = robot(m.robot_id)) {
        emit(*r, kTruth, time_of(m.header.stamp_ns), [&] { return pose_in_frame(m.header, m.pose); });
      }
    });
    diagnostics = reader<locd_msg_Diagnostics>(topics::kDiagnostics, QosProfile::kOutput, [this](const locd_msg_Diagnostics& m) {
      const Robot* r = robot(m.robot_id);
      if (!r) return;
      const uint64_t t = time_of(m.header.stamp_ns);
      if (m.particles._length > 0) emit(*r, kParticles, t, [&] { return particles(m); });
      emit(*r, kDiagnostics, t, [&] { return diagnostic_values(m); });
    });
    scan = reader<locd_msg_LaserScan>(topics::kScan, QosProfile::kSensor, [this](const locd_msg_LaserScan& m) {
      if (const Robot* r = robot(m.robot_id)) emit(*r, kScan, time_of(m.header.stamp_ns), [&] { return laser_scan(m); });
    });
    cloud = reader<locd_msg_PointCloud>(topics::kCloud, QosProfile::kSensor, [this](const locd_msg_PointCloud& m) {
      if (const Robot* r = robot(m.robot_id)) emit(*r, kCloud, time_of(m.header.stamp_ns), [&] { return sensor_cloud(m); });
    });
    landmarks = reader<locd_msg_LandmarkMap>(topics::kLandmarkMap, QosProfile::kOutputState, [this](const locd_msg_LandmarkMap& m) {
      if (const Robot* r = robot(m.robot_id)) {
        emit(*r, kLandmarks, time_of(m.header.stamp_ns), [&] { return landmark_scene(m); });
      }
    });
    map_cloud = reader<locd_msg_PointCloudMap>(topics::kMapCloud, QosProfile::kOutputState, [this](const locd_msg_PointCloudMap& m) {
      if (const Robot* r = robot(m.robot_id)) {
        emit(*r, kMapCloud, time_of(m.header.stamp_ns), [&] { return view::map_cloud(m); });
      }
    });
    goal = reader<locd_msg_ExplorationGoal>(topics::kExplorationGoal, QosProfile::kOutputState, [this](const locd_msg_ExplorationGoal& m) {
      if (const Robot* r = robot(m.robot_id)) {
        emit(*r, kGoal, time_of(m.header.stamp_ns), [&] { return exploration_goal(m); });
      }
    });
    status = reader<locd_msg_SessionStatus>(topics::kSessionStatus, QosProfile::kState, [this](const locd_msg_SessionStatus& m) {
      if (const Robot* r = robot(m.robot_id)) {
        emit(*r, kStatus, time_of(m.header.stamp_ns), [&] { return session_status(m); });
      }
    });
    grid = reader<locd_msg_GridMap>(topics::kGrid, QosProfile::kOutputState, [this](const locd_msg_GridMap& m) {
      const uint32_t channel = grid_channel(m.robot_id, dds::to_string(m.layer));
      emit(channel, true, time_of(m.header.stamp_ns), [&] { return view::grid(m); });
    });
  }

  template <typename T>
  dds::Reader<T> reader(const char* topic, dds::QosProfile qos, std::function<void(const T&)> callback) {
    // The state topics keep one sample per instance; grids are keyed by layer too.
    return dds::Reader<T>(participant, topic, qos, std::move(callback), 8, partitions);
  }

  // The robot's channels, advertised on first sight; nullptr for a robot id that is malformed or
  // beyond max_robots.
  const Robot* robot(const char (&robot_id)[65]) {
    const std::string id = dds::to_string(robot_id);
    std::lock_guard<std::mutex> lock(mutex);
    auto it = robots.find(id);
    if (it != robots.end()) return &it->second;
    if (!robot_id_error(id).empty()) return nullptr;
    if (robots.size() >= options.max_robots) {
      if (!warned_full) {
        warned_full = true;
        std::cerr << "locview: robot '" << escaped(id) << "' and later ones are not shown: " << options.max_robots
                  << " robots already (--max-robots)" << std::endl;
      }
      return nullptr;
    }
    Robot& r = robots[id];
    for (int slot = 0; slot < kSlots; ++slot) {
      const SlotInfo& s = kSlotInfo[slot];
      r.channel[slot] = server.add_channel(id, "/" + id + "/" + s.name, s.schema, json_schema(s.schema), s.latched);
    }
    return &r;
  }

  uint32_t grid_channel(const char (&robot_id)[65], const std::string& layer) {
    if (!robot(robot_id)) return 0;
    const std::string id = dds::to_string(robot_id);
    std::lock_guard<std::mutex> lock(mutex);
    Robot& r = robots[id];
    auto it = r.grids.find(layer);
    if (it != r.grids.end()) return it->second;
    if (r.grids.size() >= 16 || layer.empty()) return 0;  // bounded: a plugin publishes a few layers
    const std::string safe = escaped(layer);
    return r.grids[layer] = server.add_channel(id, "/" + id + "/grid/" + safe, "foxglove.Grid", json_schema("foxglove.Grid"), true);
  }

  template <typename Make>
  void emit(const Robot& r, Slot slot, uint64_t time, Make make) {
    emit(r.channel[slot], kSlotInfo[slot].latched, time, make);
  }
  template <typename Make>
  void emit(uint32_t channel, bool latched, uint64_t time, Make make) {
    if (channel == 0 || (!latched && !server.subscribed(channel))) return;
    server.publish(channel, time, make().dump());
  }

};

FleetView::FleetView(FoxgloveServer& server, const ViewOptions& options)
    : impl_(std::make_unique<Impl>(server, options)) {}

FleetView::~FleetView() = default;

size_t FleetView::robots() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->robots.size();
}

}  // namespace locd::view
