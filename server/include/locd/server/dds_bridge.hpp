// The server's DDS side: readers on every sensor topic, session_request, initial_pose and
// map_save_request; writers for pose, diagnostics, grid, map_cloud, landmark_map,
// exploration_goal, session_status and server_info.
// Listener callbacks convert with locd::dds::from_wire (sizes bounded by the limits before any
// allocation) and hand over to the Server; they never block.
#pragma once

#include <memory>
#include <string>

#include "locd/dds/dds.hpp"
#include "locd/server/log.hpp"
#include "locd/server/output_sink.hpp"

namespace locd::server {

class Server;

class DdsBridge : public OutputSink {
 public:
  DdsBridge(int domain_id, std::string server_id, const Limits& limits, Logger& logger);
  ~DdsBridge() override;

  // Creates the readers; from now on listener threads call into `server`.
  void connect(Server& server);
  // Deletes the readers (waits for running callbacks); writers stay until destruction.
  void disconnect();

  void publish_status(const SessionStatusReport& status) override;
  void publish_outputs(const std::string& robot_id, const std::string& plugin, const Header& header,
                       const UpdateResult& result, double update_ms) override;
  void publish_server_info(const ServerInfoReport& info) override;

 private:
  struct Readers;
  std::string server_id_;  // stamped on every status
  Limits limits_;
  Logger& logger_;
  dds::Participant participant_;
  dds::Writer<locd_msg_PoseEstimate> pose_;
  dds::Writer<locd_msg_Diagnostics> diagnostics_;
  dds::Writer<locd_msg_GridMap> grid_;
  dds::Writer<locd_msg_PointCloudMap> map_cloud_;
  dds::Writer<locd_msg_LandmarkMap> landmark_map_;
  dds::Writer<locd_msg_ExplorationGoal> exploration_goal_;
  dds::Writer<locd_msg_SessionStatus> status_;
  dds::Writer<locd_msg_ServerInfo> server_info_;
  std::unique_ptr<Readers> readers_;
};

}  // namespace locd::server
