// The server's DDS side: readers on every sensor topic, session_request, initial_pose and
// map_save_request; writers for pose, diagnostics, grid, map_cloud, landmark_map,
// exploration_goal, session_status and server_info.
// Listener callbacks convert with locd::dds::from_wire (sizes bounded by the limits before any
// allocation) and hand over to the Server; they never block.
//
// Addressing (topics.hpp): the readers subscribe in every robot's partition (robot.*) and pass on
// only samples whose robot_id is their writer's partition and a valid robot id; each robot's
// outputs are written in its own partition, by writers made on first use and released, least
// recently used first, beyond `max_robots`. The readers also track which robots still have a
// live writer (RobotWriterPresence) and tell the Server when one comes or goes.
//
// Ownership (README "Many servers"): a robot's outputs but its status (pose, diagnostics, maps,
// grids, goals) are written only while this server claims the robot, by writers with exclusive
// ownership whose strength is the claim's; a new claim of another strength makes them anew, and
// withdrawing the claim deletes them (DDS then lets the robot take another server's outputs).
// Statuses stay shared: any server may tell a robot why it is not served. Writers are deleted on
// a thread of the bridge's own: a claim is withdrawn on the DDS listener thread a stop request
// arrives on, where Cyclone's deletion of a writer would wait for that very thread.
#pragma once

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "locd/dds/dds.hpp"
#include "locd/server/log.hpp"
#include "locd/server/output_sink.hpp"
#include "locd/server/writer_presence.hpp"

namespace locd::server {

class Server;

class DdsBridge : public OutputSink {
 public:
  DdsBridge(int domain_id, std::string server_id, const Limits& limits, Logger& logger, size_t max_robots);
  ~DdsBridge() override;

  // Creates the readers; from now on listener threads call into `server`.
  void connect(Server& server);
  // Deletes the readers (waits for running callbacks); writers stay until destruction.
  void disconnect();

  void publish_status(const SessionStatusReport& status) override;
  void publish_outputs(const std::string& robot_id, const std::string& plugin, const Header& header,
                       const UpdateResult& result, double update_ms) override;
  void publish_server_info(const ServerInfoReport& info) override;
  void publish_claim(const std::string& robot_id, bool serving, int32_t strength) override;
  void republish_claims() override;
  void publish_resume_state(const std::string& robot_id, const ResumeState& state) override;

  // The bridge's participant, shared with the ROS 2 bridge (one participant per server).
  const dds::Participant& participant() const { return participant_; }

 private:
  static constexpr size_t kMaxRobotsTracked = 65536;
  struct Readers;
  struct RobotWriters;
  struct OwnedWriters;
  // The writers of one robot's partition (made if needed), marked as just used.
  std::shared_ptr<RobotWriters> writers_for(const std::string& robot_id);
  // Its output writers at the strength of this server's claim (made if needed); none when this
  // server does not claim the robot.
  std::shared_ptr<OwnedWriters> owned_writers_for(const std::string& robot_id);
  // Writers to delete, handed to the deleter thread (never deleted on the caller's thread).
  void delete_later(std::shared_ptr<void> writers);
  void deleter_loop();

  std::string server_id_;  // stamped on every status
  Limits limits_;
  Logger& logger_;
  size_t max_robots_;
  dds::Participant participant_;
  dds::Writer<locd_msg_ServerInfo> server_info_;
  dds::Writer<locd_msg_ServingClaim> claims_;        // default partition, server to server
  dds::Writer<locd_msg_ResumeState> resume_states_;  // likewise
  std::mutex fleet_mutex_;                           // the two writers above
  struct Claim {
    int64_t since_ns = 0;
    int32_t strength = 0;
  };
  std::map<std::string, Claim> claimed_;             // this server's claims (under fleet_mutex_)
  uint64_t outputs_unclaimed_ = 0;                   // outputs dropped: the robot no longer claimed (under fleet_mutex_)
  std::mutex writers_mutex_;
  std::map<std::string, std::shared_ptr<RobotWriters>> robot_writers_;
  uint64_t use_counter_ = 0;
  RobotWriterPresence presence_{kMaxRobotsTracked};  // session ownership; before the readers using it
  std::unique_ptr<Readers> readers_;
  std::mutex deleter_mutex_;
  std::condition_variable deleter_wakes_;
  std::vector<std::shared_ptr<void>> to_delete_;  // under deleter_mutex_
  bool deleter_stopping_ = false;
  std::thread deleter_;  // last: started when everything above exists
};

}  // namespace locd::server
