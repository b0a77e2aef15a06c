#include "run_recording.hpp"

#include <memory>
#include <type_traits>
#include <variant>

#include "locd/dds/convert.hpp"

namespace locd::sim {

McapRunRecording::McapRunRecording(const std::string& path, const Scenario& scenario)
    : out_(path, mcap::WriterOptions{}),
      robot_id_(scenario.robot.id),
      plugin_(scenario.localizer.plugin),
      config_text_(scenario.localizer.config_text) {}

void McapRunRecording::started(const PoseEstimate& initial_pose) {
  const uint64_t t = static_cast<uint64_t>(std::max<int64_t>(initial_pose.header.stamp_ns, 0));
  auto request = std::make_unique<locd_msg_SessionRequest>();
  dds::copy_string(request->robot_id, robot_id_);
  request->request_id = 1;
  request->action = locd_msg_SESSION_START;
  dds::copy_string(request->plugin, plugin_);
  dds::borrow_text(request->config_yaml, config_text_, topics::kMaxConfigYamlBytes);
  out_.write_sample(topics::kSessionRequest, robot_id_, t, *request);
  dds::to_wire(robot_id_, initial_pose, [&](const locd_msg_InitialPose& s) {
    out_.write_sample(topics::kInitialPose, robot_id_, t, s);
  });
}

void McapRunRecording::measurement(const Measurement& m, const Pose2& truth) {
  std::visit(
      [&](const auto& value) {
        using T = std::decay_t<decltype(value)>;
        const int64_t stamp = value.header.stamp_ns;
        last_stamp_ = stamp;
        const uint64_t t = static_cast<uint64_t>(std::max<int64_t>(stamp, 0));
        const char* topic = std::is_same_v<T, Odometry>             ? topics::kOdometry
                            : std::is_same_v<T, Imu>                ? topics::kImu
                            : std::is_same_v<T, LaserScan>          ? topics::kScan
                            : std::is_same_v<T, PointCloud>         ? topics::kCloud
                            : std::is_same_v<T, Image>              ? topics::kImage
                                                                    : topics::kDetections;
        dds::to_wire(robot_id_, value, [&](const auto& s) { out_.write_sample(topic, robot_id_, t, s); });
        if constexpr (std::is_same_v<T, Odometry>) {
          PoseEstimate truth_pose;
          truth_pose.header = {stamp, "map"};
          truth_pose.pose = truth.to_isometry();
          truth_pose.covariance = Matrix6d::Zero();
          dds::to_wire(robot_id_, truth_pose, "", 0.0, [&](const locd_msg_PoseEstimate& s) {
            out_.write_sample(topics::kGroundTruth, robot_id_, t, s);
          });
        }
      },
      m);
}

void McapRunRecording::updated(const UpdateResult& update, double update_ms) {
  const int64_t stamp = update.estimate ? update.estimate->header.stamp_ns : last_stamp_;
  const uint64_t t = static_cast<uint64_t>(std::max<int64_t>(stamp, 0));
  const Header map_header{stamp, "map"};
  if (update.estimate) {
    dds::to_wire(robot_id_, *update.estimate, plugin_, update_ms, [&](const locd_msg_PoseEstimate& s) {
      out_.write_sample(topics::kPose, robot_id_, t, s);
    });
  }
  if (!update.diagnostics.empty()) {
    dds::to_wire(robot_id_, map_header, plugin_, update.diagnostics, [&](const locd_msg_Diagnostics& s) {
      out_.write_sample(topics::kDiagnostics, robot_id_, t, s);
    });
  }
  if (update.grid) {
    dds::to_wire(robot_id_, map_header, *update.grid, [&](const locd_msg_GridMap& s) {
      out_.write_sample(topics::kGrid, robot_id_, t, s);
    });
  }
  if (update.map_cloud) {
    dds::to_wire(robot_id_, map_header, *update.map_cloud, [&](const locd_msg_PointCloudMap& s) {
      out_.write_sample(topics::kMapCloud, robot_id_, t, s);
    });
  }
  if (update.landmark_map) {
    dds::to_wire(robot_id_, map_header, *update.landmark_map, [&](const locd_msg_LandmarkMap& s) {
      out_.write_sample(topics::kLandmarkMap, robot_id_, t, s);
    });
  }
}

}  // namespace locd::sim
