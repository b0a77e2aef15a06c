// The C++ client library a robot program links to (locd::locd_client): publish sensors,
// request a localizer with YAML, set the initial pose, receive pose and status by callback.
//
//   locd::Client client({.domain_id = 0, .robot_id = "robot1"});
//   client.on_pose([](const locd::PoseUpdate& p) { ... });
//   auto status = client.request_session("feature_ekf", yaml_text, std::chrono::seconds(5));
//   if (!status.request_ok) std::cerr << status.message << "\n";
//   client.publish(odometry); client.publish(scan);
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "locd/sdk/types.hpp"

namespace locd {

// A session's state as the server reports it (mirrors locd_msg_SessionStatus).
struct SessionStatus {
  std::string robot_id;
  std::string server_id;
  std::string state;  // "starting", "running", "stopped", "error", "no_session", "restarting", "failed"
  std::string plugin;
  uint64_t request_id = 0;
  bool request_ok = false;
  std::string message;     // outcome of the last request
  std::string last_error;  // last rejected input or failure
  uint64_t received = 0, used = 0, dropped = 0, rejected = 0, updates = 0;
  double last_update_ms = 0.0;
  int64_t initial_pose_stamp_ns = 0;  // stamp of the last initial pose the plugin holds (0 = none)
  uint32_t failures = 0;              // plugin failures (crash, exit, hang, bad output)
  uint64_t lost = 0;                  // sensor messages lost in transit (sequence gaps)
  std::vector<std::pair<std::string, uint64_t>> lost_by_stream;  // topic, count (losses only)
  std::string localization = "unknown";  // "unknown", "tracking", "uncertain", "lost"
  std::string localization_reason;       // the plugin's criterion
  uint64_t held = 0;        // taken, not yet used, dropped or rejected: received = used + dropped + rejected + held
  std::string waiting_for;  // what the held messages wait for (empty when none is held)
  uint64_t throttled = 0;   // session requests, initial poses, map saves over the robot's rate limit, dropped
  int64_t stamp_ns = 0;
};

struct PoseUpdate {
  std::string robot_id;
  std::string plugin;
  PoseEstimate estimate;
  double update_ms = 0.0;        // plugin compute time for this pose
  int64_t received_wall_ns = 0;  // CLOCK_REALTIME when the client received it
};

// The next best scan pose an exploring plugin (icp_explorer) suggests, or done.
struct ExplorationGoalUpdate {
  std::string robot_id;
  std::string plugin;
  ExplorationGoal goal;  // goal.done: nothing left worth a scan
};

struct PluginInfo {
  std::string name, version, description;
  std::vector<std::string> consumes;
};

struct ServerInfo {
  std::string server_id;
  std::vector<PluginInfo> plugins;
  std::vector<std::string> rejected_plugins;
};

struct ClientOptions {
  uint32_t domain_id = 0;
  // The robot this client publishes for (1-64 characters of [A-Za-z0-9_.-]); may be empty for
  // pure watchers. Everything it publishes travels in the robot's DDS partition robot.<robot_id>.
  std::string robot_id;
  int sensor_depth = 8;    // keep-last depth of the sensor writers
  // Robots whose pose, status and goals this client receives. Empty: its own robot only, or every
  // robot when robot_id is empty too. {"*"}: every robot. A reader receives only the robots it
  // names, so N robots each watching themselves cost O(N) traffic, not O(N^2).
  std::vector<std::string> watch;
};

class Client {
 public:
  explicit Client(const ClientOptions& options);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  const std::string& robot_id() const;

  // Sensors for this client's robot. Throw std::runtime_error if DDS fails.
  void publish(const Odometry& m);
  void publish(const Imu& m);
  void publish(const LaserScan& m);
  void publish(const PointCloud& m);
  void publish(const Image& m);
  void publish(const LandmarkDetections& m);
  // Ground truth (simulators only), on locd/ground_truth.
  void publish_ground_truth(const PoseEstimate& truth);

  // Sends a session request and waits for the status that answers it (matching request_id).
  // Returns nullopt on timeout. The returned status says request_ok and the server's message.
  // A "starting" status only says the request arrived and is not taken as the answer; statuses
  // of other robots or with another request_id are never taken either. Throws
  // std::invalid_argument when plugin or config_yaml exceed their wire bounds (64 / 262144 bytes).
  std::optional<SessionStatus> request_session(const std::string& plugin, const std::string& config_yaml,
                                               std::chrono::milliseconds timeout);
  std::optional<SessionStatus> stop_session(std::chrono::milliseconds timeout);
  // Asks the server to save this robot's map (a plugin that builds one, e.g. icp_explorer) into
  // its own output directory; no path travels. Returns the answering status (message names the
  // file written, or why not), nullopt on timeout.
  std::optional<SessionStatus> save_map(std::chrono::milliseconds timeout);
  void set_initial_pose(const PoseEstimate& pose);
  // Sends the initial pose and waits until the server's status says the plugin holds it
  // (initial_pose_stamp_ns == pose.header.stamp_ns) or refused it (rejected grows, last_error
  // begins "initial pose rejected"). Sensor messages sent after this meet the new pose; without
  // the wait they may not, as DDS orders samples per topic only. Returns that status, nullopt on
  // timeout. Throws std::invalid_argument for a pose stamped 0 (give each pose a fresh stamp).
  std::optional<SessionStatus> set_initial_pose(const PoseEstimate& pose, std::chrono::milliseconds timeout);

  // Waits until a locd server is discovered (its ServerInfo is received). False on timeout.
  bool wait_for_server(std::chrono::milliseconds timeout);

  // Waits until every topic this client has written to has at least one matched reader and
  // every matched reader acknowledged what was written (call before a short-lived program exits,
  // e.g. after set_initial_pose). False on timeout.
  bool wait_for_delivery(std::chrono::milliseconds timeout);

  // Callbacks run on a DDS listener thread: copy what you need and return quickly.
  // robot_filter empty = every robot the client watches (ClientOptions::watch).
  void on_pose(std::function<void(const PoseUpdate&)> callback, const std::string& robot_filter = "");
  void on_status(std::function<void(const SessionStatus&)> callback, const std::string& robot_filter = "");
  void on_exploration_goal(std::function<void(const ExplorationGoalUpdate&)> callback,
                           const std::string& robot_filter = "");

  // Latest status per watched robot seen so far (transient-local: includes robots started earlier).
  std::vector<SessionStatus> statuses() const;
  std::vector<ServerInfo> servers() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace locd
