// The session router: one Session per robot, plugin requests configured on the worker pool,
// messages for robots without a session answered on the status topic. Free of DDS: the bridge
// calls the on_* methods (from listener threads; none of them blocks) and publishes through
// the OutputSink.
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "locd/sdk/plugin_loader.hpp"
#include "locd/server/log.hpp"
#include "locd/server/output_sink.hpp"
#include "locd/server/server_config.hpp"
#include "locd/server/session.hpp"
#include "locd/server/session_observer.hpp"
#include "locd/server/worker_pool.hpp"

namespace locd::server {

struct SessionRequestMessage {
  std::string robot_id;
  uint64_t request_id = 0;
  bool stop = false;
  std::string plugin;  // may be empty: the config's `plugin` is used
  std::string config_yaml;
};

class Server {
 public:
  Server(ServerConfig config, const PluginCatalog& catalog, OutputSink& sink, Logger& logger);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Told of every plugin config configured and every session ended (the ROS 2 bridge); before boot().
  void set_session_observer(SessionObserver* observer) { observer_ = observer; }

  // Publishes ServerInfo and starts the boot sessions of the config.
  void boot();

  void on_session_request(SessionRequestMessage request);
  void on_measurement(const std::string& robot_id, Measurement measurement);
  void on_bad_input(const std::string& robot_id, const std::string& topic, const std::string& error);
  void on_initial_pose(const std::string& robot_id, const PoseEstimate& pose);
  void on_map_save_request(const std::string& robot_id, uint64_t request_id);
  // A sample whose robot id is not allowed (robot_id.hpp), or that came from a writer outside any
  // valid robot's partition: counted and logged (escaped, at most once a second); nothing is kept
  // for it.
  void on_invalid_robot_id(const std::string& topic, const std::string& error);
  uint64_t messages_refused_for_robot_id() const;

  void publish_all_status();
  ServerInfoReport info() const;
  std::shared_ptr<Session> find(const std::string& robot_id) const;
  uint64_t messages_without_session() const;

  // Stops accepting work, discards queued tasks, joins the workers, releases every plugin.
  void shutdown();

  const ServerConfig& config() const { return config_; }
  PluginContext context_for(const std::string& robot_id);

 private:
  void start_plugin(const std::shared_ptr<Session>& session, uint64_t generation, uint64_t request_id,
                    const PluginConfig& config, const std::string& source);
  void handle_start(const std::shared_ptr<Session>& session, uint64_t generation, const SessionRequestMessage& request);
  void abandon_if_failed(const std::shared_ptr<Session>& session, uint64_t generation);
  std::shared_ptr<Session> create_session_locked(const std::string& robot_id);
  void report_no_session(const std::string& robot_id, const std::string& topic, const std::string& detail);

  ServerConfig config_;
  const PluginCatalog& catalog_;
  OutputSink& sink_;
  Logger& logger_;
  SessionObserver* observer_ = nullptr;
  WorkerPool pool_;
  int64_t started_ns_;

  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<Session>> sessions_;
  struct Unserved {
    uint64_t count = 0;
    std::chrono::steady_clock::time_point last_report{};
    bool reported = false;
  };
  std::map<std::string, Unserved> unserved_;  // robots sending without a session
  uint64_t messages_without_session_ = 0;
  uint64_t refused_robot_ids_ = 0;
  uint64_t refused_robot_ids_not_logged_ = 0;
  std::chrono::steady_clock::time_point last_refusal_log_{};
};

}  // namespace locd::server
