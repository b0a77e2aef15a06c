// ROS 2 robots without a bridge node: for each robot whose session config has a `ros2:` section
// (locd/sdk/ros2_config.hpp), readers of the standard messages its drivers already publish and
// writers of locd's outputs as ROS 2 messages, on ROS 2's topics (rt/<namespace>/<name>), types
// (<pkg>::msg::dds_::<Name>_) and QoS, in the default partition as rmw does it; and what makes it
// behave like Nav2 AMCL where a robot stack depends on it (README "ROS 2 robots").
//
// - A robot's endpoints appear when its session is configured (SessionObserver) and go when it
//   stops (deleted off the DDS listener thread the stop arrived on); a switch to a config with
//   the same ros2 section keeps them (and the pose a late joiner gets), one with another section
//   replaces them, one without removes them. Two robots may not share a topic (except tf and
//   tf_static).
// - Inputs are converted (ros2_convert.hpp: sizes bounded before allocation, the sdk checks) and
//   handed to Server::on_measurement / on_initial_pose, so the same queue, stamp order and
//   limits apply as on locd's own topics; a bad message goes to Server::on_bad_input, naming
//   the ROS 2 topic. Sensor frames come from the config or, without sensor_frames, from the
//   robot's /tf_static and /tf (TransformBuffer) at each message's stamp.
// - Outputs: it wraps the OutputSink. Every call goes on to `next` (the DDS bridge); for a robot
//   with ROS 2 endpoints its map, grids and map cloud are written as well, and, once the robot
//   has an initial pose or its plugin reports tracking (AMCL publishes nothing before an initial
//   pose), its pose, particles and map -> odom: stamped the pose's stamp + transform_tolerance,
//   with the odometry at the pose's stamp (it waits for it; past odometry_timeout the transform
//   is withheld and the status says why).
// - The robot's status problems go to /rosout as warnings (rqt_console shows them), and every
//   robot is a node (`<namespace>/locd`) in ros_discovery_info with the GIDs of its endpoints,
//   so `ros2 node list` and `ros2 topic info -v` show it.
#pragma once

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "locd/dds/dds.hpp"
#include "locd/dds/ros2.hpp"
#include "locd/sdk/plugin.hpp"
#include "locd/server/log.hpp"
#include "locd/server/output_sink.hpp"
#include "locd/server/session_observer.hpp"

namespace locd::server {

class Server;

class Ros2Bridge : public OutputSink, public SessionObserver {
 public:
  Ros2Bridge(const dds::Participant& participant, const Limits& limits, OutputSink& next, Logger& logger);
  ~Ros2Bridge() override;
  Ros2Bridge(const Ros2Bridge&) = delete;
  Ros2Bridge& operator=(const Ros2Bridge&) = delete;

  // Readers made from now on call into `server` (call before Server::boot).
  void connect(Server& server);
  // Deletes every robot's endpoints (waits for running callbacks); no more are made.
  void disconnect();

  void session_configured(const std::string& robot_id, const PluginConfig& config) override;
  void session_ended(const std::string& robot_id) override;

  void publish_status(const SessionStatusReport& status) override;
  void publish_outputs(const std::string& robot_id, const std::string& plugin, const Header& header,
                       const UpdateResult& result, double update_ms) override;
  void publish_server_info(const ServerInfoReport& info) override;
  void publish_claim(const std::string& robot_id, bool serving, int32_t strength) override {
    next_.publish_claim(robot_id, serving, strength);
  }
  void republish_claims() override { next_.republish_claims(); }
  void publish_resume_state(const std::string& robot_id, const ResumeState& state) override {
    next_.publish_resume_state(robot_id, state);
  }

  // Robots with ROS 2 endpoints now.
  std::vector<std::string> robots() const;

 private:
  struct Robot;
  // /rosout, for every robot: `name` is the robot's logger (e.g. "robot1.locd").
  void rosout(uint8_t level, const std::string& name, const std::string& text);
  // Writes ros_discovery_info: this participant's nodes, one per robot, with their GIDs.
  void publish_discovery();
  // Hands a robot's endpoints over for deletion. A stop request arrives on a DDS listener thread,
  // which must not delete DDS entities (Cyclone's deletion waits for that very thread): they are
  // deleted on the reaper thread, or by reap() on a worker.
  void retire(std::shared_ptr<Robot> robot);
  // Deletes every retired robot's endpoints (on this thread), waiting for those being deleted.
  void reap();
  void reaper_loop();

  const dds::Participant& participant_;
  Limits limits_;
  OutputSink& next_;
  Logger& logger_;
  std::mutex config_mutex_;   // one robot's endpoints made or removed at a time
  mutable std::mutex mutex_;  // guards server_ and robots_
  Server* server_ = nullptr;
  std::map<std::string, std::shared_ptr<Robot>> robots_;

  std::mutex graph_mutex_;  // guards the writers below, made with the first robot
  std::unique_ptr<dds::Writer<dds::ros2::ParticipantEntitiesInfo>> discovery_;
  std::unique_ptr<dds::Writer<dds::ros2::Log>> rosout_;

  std::mutex retired_mutex_;
  std::condition_variable retired_changed_;
  std::vector<std::shared_ptr<Robot>> retired_;
  int deleting_ = 0;       // batches being deleted now
  bool stopping_ = false;
  std::thread reaper_;     // last: started when everything above exists
};

}  // namespace locd::server
