// One robot's session: its plugin instance (in a worker process, plugin_workers.hpp), a bounded
// queue ordered by stamp, where it resumes from, and its counters.
//
// - push() runs on a DDS listener thread and never blocks beyond a short lock: it checks the
//   stamp against the last accepted one of the same kind, inserts at the sorted position and,
//   when the queue is full, drops the oldest sensor frame (scan, cloud, image, detections);
//   odometry and IMU go only when nothing else is queued, so frames that are processed are
//   never placed with a motion stream that has holes in it.
// - The session is serial: at most one request of it is with its worker at a time. Control work
//   (an initial pose, the pose handed over after a switch or a restart, a map save) goes ahead of
//   queued measurements. Replies arrive on the workers' I/O thread, which publishes the outputs
//   and sends the next request.
// - A request configures the plugin on a worker while the running plugin (if any) carries on;
//   only the newest request installs its plugin, and a failed one leaves the running plugin be.
// - When the plugin's worker dies or hangs, the session restarts the plugin from where the robot
//   is (resume.hpp): at once when another session's request killed the worker, after a backoff
//   that doubles when its own did; after max_failures in a row it stops and is marked failed.
//   The status names the plugin, the signal or exit code and the message it was handling.
// - Rejections are counted and named on the status topic one by one; the log gets at most
//   kRejectionLinesPerSecond lines per session per second, and says how many it left out.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/plugin_loader.hpp"
#include "locd/server/output_sink.hpp"
#include "locd/server/plugin_workers.hpp"
#include "locd/server/resume.hpp"
#include "locd/server/worker_pool.hpp"

namespace locd::server {

using SessionLog = std::function<void(LogLevel, const std::string&)>;

// The DDS topic a measurement kind arrives on (for messages).
const char* topic_of(MeasurementKind kind);

class Session;

// What every session shares: where plugins run, where outputs go, and the server's settings.
struct SessionEnvironment {
  PluginWorkers& workers;
  WorkerPool& pool;  // statuses caused on listener threads are written here
  OutputSink& sink;
  size_t queue_depth = 64;
  FailurePolicy failures;
  worker::ConfigureRequest configure_template;  // limits, map and output directories
  // Called (off the session's lock) when a session whose first request failed is abandoned.
  std::function<void(const std::shared_ptr<Session>&)> forget;
  // True while the outputs of updates must be withheld (Server::outputs_withheld: this server may
  // have been taken over while it was stalled); they are dropped, the session goes on.
  std::function<bool()> outputs_withheld;
};

class Session : public InstanceOwner, public std::enable_shared_from_this<Session> {
 public:
  static constexpr int kRejectionLinesPerSecond = 5;

  Session(std::string robot_id, SessionEnvironment& environment, SessionLog log);

  const std::string& robot_id() const { return robot_id_; }

  // A converted measurement from the bridge. Returns false when the session has stopped.
  bool push(Measurement measurement);
  // A message the bridge could not convert: counted as received and rejected.
  void reject_input(const std::string& error);
  // A request, initial pose or map save dropped over a rate limit: counted as throttled (not as
  // received) and the status's last_error. (The server logs them, once a second for all robots.)
  void throttle(const std::string& message);
  // A problem with the robot's outputs that is no rejected input (the ROS 2 bridge withholding
  // map -> odom): the status's last_error and the log.
  void report_output_problem(const std::string& problem);
  // Initial pose (from the topic or a boot config), ahead of queued measurements.
  void set_pose(const PoseEstimate& pose);
  // A map save request: Localizer::save_map() runs in the plugin's turn; the file written or the
  // refusal becomes the status message of request_id.
  void save_map(uint64_t request_id);

  // Each request gets a generation; only the newest one may install its plugin. It also forgets
  // the last accepted stamps, so a restarted robot whose clock begins again is accepted.
  uint64_t begin_request(uint64_t request_id);
  // Configures `plugin` on a worker; when it answers, the plugin is installed (the
  // running one, if any, released), handed the robot's pose and its initial outputs published.
  // A request superseded meanwhile is discarded.
  void start(uint64_t generation, uint64_t request_id, std::shared_ptr<const PluginDescription> plugin,
             PluginConfigText config, const std::string& source);
  // The request failed before reaching a worker: the running plugin (if any) keeps running, the
  // status carries the error. Returns true when the session has a plugin running. The caller
  // publishes the status (after forgetting a session left without a plugin).
  bool fail_request(uint64_t generation, uint64_t request_id, const std::string& error);
  // After a failed request: if `generation` is still the newest and no plugin runs, the session
  // is marked stopped (its router then forgets it) and true is returned.
  bool abandon_if_idle(uint64_t generation);
  // Ends the session: the plugin is released, queued messages are discarded (counted as dropped).
  void stop(uint64_t request_id, const std::string& message);

  // A restarted server's saved state for this robot: the plugin resumes from it, and initial
  // poses stamped before it (transient-local replays of old ones) are refused as stale.
  void seed(const ResumeState& state);
  // True when `request_id` is the request whose plugin failed max_failures times before the
  // server restarted (a poison request replayed at start-up is not started again).
  bool failed_before_restart(uint64_t request_id) const;
  // Marks the session failed for that request again (and publishes the status), so the state
  // file keeps saying so.
  void refuse_failed_request(uint64_t request_id, const std::string& error);
  // What to save for a server restart: nothing before the first estimate, unless failed.
  std::optional<ResumeState> resume_state() const;

  SessionStatusReport status() const;
  void publish_status() const;
  // From a listener thread: the status is written on the pool, never blocking the listener.
  // Calls made while one is pending share it (a flood of bad input is one status, not one each).
  void publish_status_later();

  // InstanceOwner: the worker's answers, on the workers' I/O thread.
  void on_reply(uint64_t instance, worker::Reply reply) override;
  void on_log(uint64_t instance, const worker::LogLine& line) override;
  void on_lost(uint64_t instance, const WorkerLoss& loss) override;

 private:
  struct Plugin {
    uint64_t instance = 0;  // 0: none alive (its worker was lost)
    std::string name;
    std::shared_ptr<const PluginDescription> description;
    PluginConfigText config;
    std::string source;
    uint64_t request_id = 0;
  };
  struct Pending {
    Plugin plugin;
    uint64_t generation = 0;
    bool restart = false;  // a restart after a failure, not a request
  };
  struct Control {
    enum class Kind { kInitialPose, kResumePose, kSaveMap } kind;
    PoseEstimate pose;
    uint64_t request_id = 0;
  };
  struct InFlight {
    uint64_t instance = 0;
    std::string plugin;
    std::optional<Measurement> measurement;
    std::optional<Control> control;
    std::string what;  // names it in messages
  };
  // What to publish once the lock is released (ordering: replies come on one thread).
  struct Publication {
    std::optional<UpdateResult> outputs;
    std::string plugin;
    Header header;
    double update_ms = 0.0;
    bool of_update = false;  // outputs of an update (not a plugin's initial ones): may be withheld
    bool status = false;
    std::vector<uint64_t> release;
    bool forget = false;
    std::vector<std::pair<LogLevel, std::string>> log;
  };

  void pump_locked();
  // An initial pose not refused as stale: it supersedes the saved state and a resumed pose not
  // yet handed over, and goes to the plugin (or is kept for the plugin still starting).
  void take_initial_pose_locked(const PoseEstimate& pose, Publication& out);
  // Where to resume when the plugin's next message is queue_.front() (which must exist).
  PoseEstimate pose_at_next_message_locked() const;
  void configure_on_worker(Pending pending);
  void handle_configured_locked(Pending pending, worker::Reply& reply, Publication& out);
  void handle_update_locked(InFlight& done, worker::Reply& reply, Publication& out);
  void handle_control_locked(InFlight& done, worker::Reply& reply, Publication& out);
  // A request that did not get its plugin configured.
  void fail_pending_locked(uint64_t request_id, const std::string& error, Publication& out);
  void register_failure_locked(const std::string& description, Publication& out);
  void schedule_restart_locked(std::chrono::duration<double> delay);
  void restart(uint64_t generation);
  bool plugin_alive_locked() const { return current_ && current_->instance != 0; }
  // Messages taken and not yet used, dropped or rejected; and what they wait for (the status).
  size_t held_locked() const;
  std::string waiting_for_locked() const;
  void finish(Publication& out);
  void log(LogLevel level, const std::string& message) const;
  // A rejected message: logged within the per-second budget, else counted as not logged.
  void log_rejection(const std::string& error);

  const std::string robot_id_;
  SessionEnvironment& env_;
  SessionLog log_;

  mutable std::mutex mutex_;
  std::deque<Measurement> queue_;  // sorted by stamp, oldest at the front
  std::deque<Control> control_;
  std::optional<InFlight> in_flight_;
  std::optional<uint64_t> release_after_reply_;  // a replaced plugin, released once it answers
  std::array<std::optional<int64_t>, 6> last_stamp_;  // per measurement kind (variant index)
  std::array<uint64_t, 6> last_sequence_{};           // per measurement kind; 0 = none yet
  SessionCounters counters_;
  std::optional<Plugin> current_;  // the plugin serving the session (instance 0 while restarting)
  std::optional<Pending> pending_;  // a plugin being configured
  SessionState state_ = SessionState::kStarting;
  uint64_t request_id_ = 0;
  bool request_ok_ = false;
  std::string message_;
  std::string last_error_;
  std::optional<ResumeState> resume_;  // where the plugin resumes from
  std::optional<Odometry> last_odometry_sent_;
  std::optional<Odometry> newest_odometry_;
  std::optional<ResumeState> seeded_;  // from the state file of the server's previous run
  bool resume_from_seed_ = false;      // resume_ is the seeded state, not yet confirmed by the robot
  int64_t initial_pose_stamp_ns_ = 0;  // last initial pose the plugin holds
  LocalizationAssessment localization_;  // from the plugin's last judged update
  uint64_t latest_generation_ = 0;
  bool stopped_ = false;
  uint32_t failures_ = 0;          // all plugin failures of the session
  uint32_t failures_in_a_row_ = 0;
  std::optional<uint64_t> failed_request_id_;
  std::chrono::steady_clock::time_point running_since_{};

  std::atomic<bool> status_pending_{false};
  std::mutex rejection_log_mutex_;
  std::chrono::steady_clock::time_point rejection_window_start_{};
  int rejection_lines_in_window_ = 0;
  uint64_t rejections_not_logged_ = 0;
};

}  // namespace locd::server
