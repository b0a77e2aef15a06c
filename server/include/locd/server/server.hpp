// The session router: one Session per robot, plugins run in worker processes (PluginWorkers),
// messages for robots without a session answered on the status topic, and the sessions' resume
// states kept in the state directory for the next run. Free of DDS: the bridge calls the on_*
// methods (from listener threads; none of them blocks) and publishes through the OutputSink.
#pragma once

#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>

#include "locd/server/fleet.hpp"
#include "locd/server/log.hpp"
#include "locd/server/output_sink.hpp"
#include "locd/server/plugin_index.hpp"
#include "locd/server/plugin_workers.hpp"
#include "locd/server/resume.hpp"
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
  // Who wrote it: the writer's DDS participant (hex GUID; with DDS Security an authenticated
  // identity's), for its rate limit across the robots it names. Empty: not known (boot, tests).
  std::string source;
};

class Server {
 public:
  Server(ServerConfig config, const PluginIndex& catalog, OutputSink& sink, Logger& logger);
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
  // An output withheld for a reason the robot should see (Session::report_output_problem).
  void on_output_problem(const std::string& robot_id, const std::string& problem);
  void on_initial_pose(const std::string& robot_id, const PoseEstimate& pose);
  void on_map_save_request(const std::string& robot_id, uint64_t request_id);
  // A sample whose robot id is not allowed (robot_id.hpp), or that came from a writer outside any
  // valid robot's partition: counted and logged (escaped, at most once a second); nothing is kept
  // for it.
  void on_invalid_robot_id(const std::string& topic, const std::string& error);
  uint64_t messages_refused_for_robot_id() const;
  // Requests, initial poses and map saves dropped over a rate limit (request_limits).
  uint64_t requests_throttled() const;

  // Session ownership (session_ownership.cpp). The bridge reports when the last live writer of a
  // robot's requests and sensor data is gone (alive false) or one is back (alive true); a session
  // a remote request started ends session_grace_s after its robot went, unless it came back.
  // Boot sessions are exempt. end_ownerless_sessions() runs from the server's periodic loop.
  void on_robot_writers(const std::string& robot_id, bool alive);
  void end_ownerless_sessions();

  // The fleet's other servers (from the bridge): alive or gone, what they serve, where their
  // robots would resume. Decisions follow in rebalance().
  void on_server_alive(const ServerMember& member);
  void on_server_gone(const std::string& server_id);  // its writer was deleted (a clean stop)
  void on_claim(const std::string& robot_id, const std::string& server_id, bool serving, int64_t since_ns = 0,
                int32_t strength = 0);
  void on_peer_resume_state(const std::string& robot_id, const std::string& server_id, const ResumeState& state);
  // Applies the fleet's rules (fleet.hpp) to every robot whose latest request asks for a
  // session: starts the ones this server should take (from where they were), stops the ones it
  // should hand back. Cheap when nothing changed; called from the server's loop.
  void rebalance();

  void publish_all_status();
  // True while this server withholds every session's outputs: it was stalled (its loop, which
  // writes its heartbeat, ran late by kServerSilence or more) while other servers knew it, so
  // they may have taken its robots over; it hears the fleet again first (its robots' claims),
  // for kRelistenAfterStall. DDS ownership already keeps a taken-over robot's locd outputs from
  // it; this also covers the ROS 2 topics, which are keyless and shared.
  bool outputs_withheld() const;
  const ServerInfoReport& info() const { return info_; }
  std::shared_ptr<Session> find(const std::string& robot_id) const;
  uint64_t messages_without_session() const;

  // Shares every session's resume state with the other servers (those that changed), and writes
  // them to the state directory (when it has one and anything changed since the last call); I/O
  // errors are logged. Called once per status period.
  void save_state();

  // Stops accepting work, discards queued tasks, ends every worker process (killing those that
  // do not exit within `grace`), releases every session.
  void shutdown(std::chrono::milliseconds grace = std::chrono::milliseconds(1000));

  const ServerConfig& config() const { return config_; }
  PluginWorkers& workers() { return workers_; }

 private:
  void start_plugin(const std::shared_ptr<Session>& session, uint64_t generation, uint64_t request_id,
                    const std::string& plugin, const PluginConfigText& text, const std::string& source);
  void handle_start(const std::shared_ptr<Session>& session, uint64_t generation, const SessionRequestMessage& request);
  void abandon_if_failed(const std::shared_ptr<Session>& session, uint64_t generation);
  std::shared_ptr<Session> create_session_locked(const std::string& robot_id);
  // Starts, keeps or hands back the robot's session as the fleet's rules say (on the pool).
  void reconsider(const std::string& robot_id);
  // Whether this server answers for a robot without a session ("no session" statuses): not when
  // another live server serves it or ranks first for it.
  bool answers_for(const std::string& robot_id) const;
  // Writes the claims made or withdrawn under mutex_ (call after releasing it).
  void publish_claims();
  void forget_server_locked(const std::string& server_id);
  void note_claim_strength_locked(const std::string& robot_id, int32_t strength);
  // Erases a session from the router (claim withdrawn); under mutex_.
  void forget_locked(std::map<std::string, std::shared_ptr<Session>>::iterator it);
  void report_no_session(const std::string& robot_id, const std::string& topic, const std::string& detail);
  // A session request (or stop) this server answers with a refusal: state no_session, the
  // request not ok, `message` saying why. Written on the pool, so callable under the lock.
  void publish_refusal(const std::string& robot_id, uint64_t request_id, std::string message);
  // The robot's rate limit (request_limits): true when `what` may be acted on; otherwise it is
  // counted as throttled on the robot's status (if it has a session here) and in the log, and a
  // session request (`request_id`) is answered as refused, at most once a second per robot and
  // 20 a second in all.
  // `source`: the writer's participant, whose session requests are limited across the robots it names.
  bool admit(const std::string& robot_id, RequestKind kind, const std::string& what, uint64_t request_id = 0,
             const std::string& source = "");

  ServerConfig config_;
  const PluginIndex& catalog_;
  OutputSink& sink_;
  Logger& logger_;
  SessionObserver* observer_ = nullptr;
  WorkerPool pool_;
  PluginWorkers workers_;
  SessionEnvironment environment_;
  RequestLimiter limiter_;            // per robot
  RequestLimiter source_limiter_;     // per writer participant (session requests)
  RequestLimiter answers_per_robot_;  // answers to dropped session requests, per robot
  RequestLimiter answers_;            // the same, every robot together (one key)
  StateFile state_file_;
  int64_t started_ns_;
  std::chrono::steady_clock::time_point started_;

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
  uint64_t throttled_ = 0;                    // requests over a limit (the robot's or its writer's), every robot
  uint64_t throttled_not_logged_ = 0;         // of those, since the last line logged (one a second)
  std::chrono::steady_clock::time_point last_throttle_log_{};
  std::map<std::string, ResumeState> saved_;  // the last run's states, given to sessions as they start
  // The latest start request of every robot (served here or elsewhere), and which one this
  // server acted on; the fleet's view; the other servers' resume states.
  struct StoredRequest {
    SessionRequestMessage request;
    std::string group;
    uint64_t handled_request_id = 0;
    bool handled = false;
  };
  std::map<std::string, StoredRequest> requests_;
  FleetView fleet_;
  const ServerInfoReport info_;  // announced at boot and then every heartbeat
  bool fleet_changed_ = false;
  std::chrono::steady_clock::time_point last_rebalance_{};
  std::chrono::steady_clock::time_point last_announce_ = std::chrono::steady_clock::now();  // boot() announced
  std::map<std::string, std::chrono::steady_clock::time_point> server_heard_;  // other servers' last ServerInfo
  // When a server was last found gone: a robot is taken over only if heard after that (a server
  // cut off hears none of them).
  std::chrono::steady_clock::time_point last_server_gone_{};
  std::map<std::string, ResumeState> peer_states_;
  std::map<std::string, std::pair<int64_t, bool>> shared_;  // robot -> stamp, failed last shared
  uint64_t messages_served_elsewhere_ = 0;
  struct ClaimChange {
    std::string robot_id;
    bool serving = false;
    int32_t strength = 0;
  };
  std::vector<ClaimChange> claims_to_publish_;  // under mutex_
  // The strongest claim known on each robot (this server's, others', the state file's): a new
  // claim is made stronger (claim_strength).
  std::map<std::string, int32_t> strongest_claim_;
  std::mutex claims_mutex_;                                      // orders publish_claims()
  // Robots another server served, and since when and until when this server heard each without
  // a break (any message): a robot is taken over only while it is heard and after it has been
  // heard for a while, so a server cut off from the network takes none, and takes none when its
  // network comes back before discovery shows it the other servers again.
  std::set<std::string> served_elsewhere_;
  struct Heard {
    std::chrono::steady_clock::time_point since, last;
  };
  std::map<std::string, Heard> last_heard_;
  std::string last_saved_;                     // what save_state wrote last (to skip unchanged writes)
  // The stall fence (outputs_withheld): steady-clock ns of the loop's last rebalance, and until
  // when outputs are withheld; whether other servers were known.
  std::atomic<int64_t> last_tick_ns_{0};
  std::atomic<int64_t> withheld_until_ns_{0};
  std::atomic<bool> others_known_{false};
  mutable std::atomic<uint64_t> outputs_withheld_count_{0};
  std::map<std::string, std::chrono::steady_clock::time_point> ownerless_since_;  // robots with a session only
};

}  // namespace locd::server
