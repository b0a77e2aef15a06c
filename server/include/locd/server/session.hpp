// One robot's session: its localizer, a bounded queue ordered by stamp, and its counters.
//
// - push() runs on a DDS listener thread and never blocks beyond a short lock: it checks the
//   stamp against the last accepted one of the same kind, inserts at the sorted position and,
//   when the queue is full, drops the oldest sensor frame (scan, cloud, image, detections);
//   odometry and IMU go only when nothing else is queued, so frames that are processed are
//   never placed with a motion stream that has holes in it.
// - The queue drains on the worker pool as a strand: at most one drain task is scheduled at a
//   time, so the plugin never sees two calls at once. Control work (install a plugin, set the
//   pose, stop) goes through the same strand, ahead of queued measurements.
// - A plugin switch is configured elsewhere (on the pool) and only installed here; the new
//   plugin gets the last published pose through set_pose.
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

#include "locd/sdk/plugin_loader.hpp"
#include "locd/server/output_sink.hpp"
#include "locd/server/worker_pool.hpp"

namespace locd::server {

using SessionLog = std::function<void(LogLevel, const std::string&)>;

// The DDS topic a measurement kind arrives on (for messages).
const char* topic_of(MeasurementKind kind);

class Session : public std::enable_shared_from_this<Session> {
 public:
  static constexpr int kRejectionLinesPerSecond = 5;

  Session(std::string robot_id, WorkerPool& pool, OutputSink& sink, size_t queue_depth, SessionLog log);

  const std::string& robot_id() const { return robot_id_; }

  // A converted measurement from the bridge. Returns false when the session has stopped.
  bool push(Measurement measurement);
  // A message the bridge could not convert: counted as received and rejected.
  void reject_input(const std::string& error);
  // Initial pose (from the topic or a boot config): applied on the session's strand.
  void set_pose(const PoseEstimate& pose);
  // A map save request: Localizer::save_map() runs on the strand (the plugin writes into the
  // directory its own config names); the file written or the refusal becomes the status message
  // of request_id.
  void save_map(uint64_t request_id);

  // Each request gets a generation; only the newest one may install its plugin. It also forgets
  // the last accepted stamps, so a restarted robot whose clock begins again is accepted.
  uint64_t begin_request(uint64_t request_id);
  // Installs a configured plugin on the strand, hands it the last pose and publishes its
  // initial outputs; a request superseded meanwhile is discarded.
  void install(uint64_t generation, uint64_t request_id, LocalizerPtr localizer, const std::string& plugin,
               const std::string& message);
  // The request failed: the running plugin (if any) keeps running, the status carries the error.
  // Returns true when the session has a plugin running. The caller publishes the status (after
  // forgetting a session left without a plugin, so the status never shows a stale session).
  bool fail_request(uint64_t generation, uint64_t request_id, const std::string& error);
  // After a failed request: if `generation` is still the newest and no plugin runs, the session
  // is marked stopped (its router then forgets it) and true is returned.
  bool abandon_if_idle(uint64_t generation);
  // Ends the session: the plugin is released on the strand, queued messages are discarded
  // (and counted as dropped).
  void stop(uint64_t request_id, const std::string& message);

  SessionStatusReport status() const;
  void publish_status() const;
  // From a listener thread: the status is written on the pool, never blocking the listener.
  // Calls made while one is pending share it (a flood of bad input is one status, not one each).
  void publish_status_later();

 private:
  void post_control(std::function<void()> work);
  void schedule_drain_locked();
  void drain();
  void process(Measurement& measurement);
  void log(LogLevel level, const std::string& message) const;
  // A rejected message: logged within the per-second budget, else counted as not logged.
  void log_rejection(const std::string& error);

  const std::string robot_id_;
  WorkerPool& pool_;
  OutputSink& sink_;
  const size_t queue_depth_;
  SessionLog log_;

  mutable std::mutex mutex_;
  std::deque<Measurement> queue_;  // sorted by stamp, oldest at the front
  std::deque<std::function<void()>> control_;
  bool drain_scheduled_ = false;
  std::array<std::optional<int64_t>, 6> last_stamp_;  // per measurement kind (variant index)
  SessionCounters counters_;
  LocalizerPtr localizer_;  // replaced only on the strand, under mutex_
  std::string plugin_;
  SessionState state_ = SessionState::kStarting;
  uint64_t request_id_ = 0;
  bool request_ok_ = false;
  std::string message_;
  std::string last_error_;
  std::optional<PoseEstimate> last_pose_;
  int64_t initial_pose_stamp_ns_ = 0;  // last initial pose the plugin holds
  LocalizationAssessment localization_;  // from the plugin's last judged update
  uint64_t latest_generation_ = 0;
  bool stopped_ = false;

  std::atomic<bool> status_pending_{false};
  std::mutex rejection_log_mutex_;
  std::chrono::steady_clock::time_point rejection_window_start_{};
  int rejection_lines_in_window_ = 0;
  uint64_t rejections_not_logged_ = 0;
};

}  // namespace locd::server
