#include "locd/server/session.hpp"

#include <algorithm>
#include <chrono>

#include "locd/dds/topics.hpp"

namespace locd::server {
namespace {

// Measurements one drain task handles before it yields its worker to other sessions.
constexpr int kDrainBatch = 32;

Header map_header(int64_t stamp_ns) { return {stamp_ns, "map"}; }

}  // namespace

int64_t wall_clock_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

const char* session_state_name(SessionState state) {
  switch (state) {
    case SessionState::kStarting: return "starting";
    case SessionState::kRunning: return "running";
    case SessionState::kStopped: return "stopped";
    case SessionState::kError: return "error";
    case SessionState::kNoSession: return "no_session";
    case SessionState::kRestarting: return "restarting";
    case SessionState::kFailed: return "failed";
  }
  return "error";
}

const char* topic_of(MeasurementKind kind) {
  switch (kind) {
    case MeasurementKind::kOdometry: return topics::kOdometry;
    case MeasurementKind::kImu: return topics::kImu;
    case MeasurementKind::kLaserScan: return topics::kScan;
    case MeasurementKind::kPointCloud: return topics::kCloud;
    case MeasurementKind::kImage: return topics::kImage;
    case MeasurementKind::kLandmarkDetections: return topics::kDetections;
  }
  return "locd/unknown";
}

Session::Session(std::string robot_id, WorkerPool& pool, OutputSink& sink, size_t queue_depth, SessionLog log)
    : robot_id_(std::move(robot_id)), pool_(pool), sink_(sink), queue_depth_(std::max<size_t>(1, queue_depth)),
      log_(std::move(log)) {}

void Session::log(LogLevel level, const std::string& message) const {
  if (log_) log_(level, message);
}

void Session::log_rejection(const std::string& error) {
  std::string line;
  {
    std::lock_guard<std::mutex> lock(rejection_log_mutex_);
    const auto now = std::chrono::steady_clock::now();
    if (now - rejection_window_start_ >= std::chrono::seconds(1)) {
      rejection_window_start_ = now;
      rejection_lines_in_window_ = 0;
    }
    if (rejection_lines_in_window_ >= kRejectionLinesPerSecond) {
      ++rejections_not_logged_;
      return;
    }
    ++rejection_lines_in_window_;
    line = "rejected: " + error;
    if (rejections_not_logged_ > 0) {
      line += " (" + std::to_string(rejections_not_logged_) +
              " earlier rejections were counted on the status topic but not logged)";
      rejections_not_logged_ = 0;
    }
    if (rejection_lines_in_window_ == kRejectionLinesPerSecond) {
      line += " (further rejections this second are counted, not logged)";
    }
  }
  log(LogLevel::kWarning, line);
}

bool Session::push(Measurement measurement) {
  const size_t kind_index = measurement.index();
  const int64_t stamp = header_of(measurement).stamp_ns;
  std::string error;
  const char* dropped = nullptr;  // topic of the message dropped from a full queue
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopped_) return false;
    ++counters_.received;
    auto& last = last_stamp_[kind_index];
    if (last && stamp < *last) {
      ++counters_.rejected;
      error = std::string("stamp going backwards on ") + topic_of(kind_of(measurement)) + ": " +
              std::to_string(stamp) + " < " + std::to_string(*last) + " ns";
      last_error_ = error;
    } else {
      last = stamp;
      auto position = std::upper_bound(queue_.begin(), queue_.end(), stamp, [](int64_t s, const Measurement& m) {
        return s < header_of(m).stamp_ns;
      });
      queue_.insert(position, std::move(measurement));
      if (queue_.size() > queue_depth_) {
        // The oldest sensor frame goes first: odometry and IMU carry the motion every later
        // frame is placed with, and a plugin that lost them would place frames at stale poses.
        auto victim = std::find_if(queue_.begin(), queue_.end(), [](const Measurement& m) {
          const MeasurementKind kind = kind_of(m);
          return kind != MeasurementKind::kOdometry && kind != MeasurementKind::kImu;
        });
        if (victim == queue_.end()) victim = queue_.begin();
        dropped = topic_of(kind_of(*victim));
        queue_.erase(victim);
        ++counters_.dropped;
      }
      if (localizer_) schedule_drain_locked();
    }
  }
  if (!error.empty()) {
    log_rejection(error);
    publish_status_later();
  } else if (dropped) {
    log(LogLevel::kDebug, "queue full (" + std::to_string(queue_depth_) + "): dropped the oldest message on " + dropped);
  }
  return true;
}

void Session::reject_input(const std::string& error) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.received;
    ++counters_.rejected;
    last_error_ = error;
  }
  log_rejection(error);
  publish_status_later();
}

void Session::publish_status_later() {
  if (status_pending_.exchange(true)) return;
  auto self = shared_from_this();
  pool_.post([self] {
    self->status_pending_ = false;  // before reading: a later rejection schedules another status
    self->publish_status();
  });
}

void Session::set_pose(const PoseEstimate& pose) {
  auto self = shared_from_this();
  post_control([this, self, pose] {
    Localizer* localizer = nullptr;
    // The initial pose counts as received and, once the plugin holds it, used; the status
    // published here, naming its stamp, is the robot's acknowledgement that later messages meet
    // the new pose (DDS orders samples per topic only).
    auto hold = [&] {
      std::lock_guard<std::mutex> lock(mutex_);
      ++counters_.used;
      initial_pose_stamp_ns_ = pose.header.stamp_ns;
    };
    {
      std::lock_guard<std::mutex> lock(mutex_);
      last_pose_ = pose;
      localizer = localizer_.get();
      ++counters_.received;
    }
    if (!localizer) {
      hold();  // handed to the plugin when it is installed
      log(LogLevel::kInfo, "initial pose kept for the plugin still starting");
      publish_status();
      return;
    }
    try {
      localizer->set_pose(pose);
      hold();
      log(LogLevel::kInfo, "initial pose set: x " + std::to_string(pose.pose.translation().x()) + ", y " +
                               std::to_string(pose.pose.translation().y()));
    } catch (const std::exception& e) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        ++counters_.rejected;
        last_error_ = std::string("initial pose rejected by plugin '") + plugin_ + "': " + e.what();
      }
      log(LogLevel::kWarning, std::string("initial pose rejected: ") + e.what());
    }
    publish_status();
  });
}

uint64_t Session::begin_request(uint64_t request_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  // A request (re)starts the stream: a robot that restarted with its clock from zero is served.
  last_stamp_.fill(std::nullopt);
  return ++latest_generation_;
}

void Session::install(uint64_t generation, uint64_t request_id, LocalizerPtr localizer, const std::string& plugin,
                      const std::string& message) {
  auto self = shared_from_this();
  auto incoming = std::make_shared<LocalizerPtr>(std::move(localizer));
  post_control([this, self, generation, request_id, incoming, plugin, message] {
    LocalizerPtr previous;
    std::string previous_plugin;
    std::optional<PoseEstimate> pose;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stopped_ || generation != latest_generation_) {
        log(LogLevel::kInfo, "request " + std::to_string(request_id) + " for plugin " + plugin +
                                 " superseded by a newer request; not installed");
        return;
      }
      previous = std::move(localizer_);
      previous_plugin = plugin_;
      localizer_ = std::move(*incoming);
      plugin_ = plugin;
      state_ = SessionState::kRunning;
      request_id_ = request_id;
      request_ok_ = true;
      message_ = message;
      pose = last_pose_;
    }
    previous.reset();
    if (pose) {
      try {
        localizer_->set_pose(*pose);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(mutex_);
        last_error_ = "plugin '" + plugin + "' refused the handed-over pose: " + e.what();
      }
    }
    try {
      const UpdateResult initial = localizer_->initial_outputs();
      sink_.publish_outputs(robot_id_, plugin, map_header(wall_clock_ns()), initial, 0.0);
    } catch (const std::exception& e) {
      log(LogLevel::kError, "initial outputs of plugin " + plugin + " not published: " + e.what());
    }
    if (previous_plugin.empty()) {
      log(LogLevel::kInfo, "session started: plugin " + plugin);
    } else {
      log(LogLevel::kInfo, "switched plugin " + previous_plugin + " -> " + plugin +
                               (pose ? " (last pose handed over)" : " (no pose to hand over yet)"));
    }
    publish_status();
  });
}

bool Session::fail_request(uint64_t generation, uint64_t request_id, const std::string& error) {
  bool running = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    running = localizer_ != nullptr;
    if (generation != latest_generation_) return running;
    request_id_ = request_id;
    request_ok_ = false;
    message_ = error;
    last_error_ = error;
    if (!running) state_ = SessionState::kError;
  }
  log(LogLevel::kWarning, "request " + std::to_string(request_id) + " failed" +
                              (running ? " (the running plugin carries on): " : ": ") + error);
  return running;
}

bool Session::abandon_if_idle(uint64_t generation) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (generation != latest_generation_ || localizer_) return false;
  stopped_ = true;
  counters_.dropped += queue_.size();
  queue_.clear();
  return true;
}

void Session::save_map(uint64_t request_id) {
  auto self = shared_from_this();
  post_control([this, self, request_id] {
    Localizer* localizer = nullptr;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      localizer = localizer_.get();
    }
    std::string message;
    bool ok = false;
    if (!localizer) {
      message = "map save request " + std::to_string(request_id) + " refused: no plugin running";
    } else {
      try {
        message = "map saved to " + localizer->save_map();
        ok = true;
      } catch (const std::exception& e) {
        message = "map save request " + std::to_string(request_id) + " refused: " + e.what();
      }
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      request_id_ = request_id;
      request_ok_ = ok;
      message_ = message;
      if (!ok) last_error_ = message;
    }
    log(ok ? LogLevel::kInfo : LogLevel::kWarning, message);
    publish_status();
  });
}

void Session::stop(uint64_t request_id, const std::string& message) {
  auto self = shared_from_this();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopped_ = true;
    ++latest_generation_;  // a plugin still being configured is never installed
    counters_.dropped += queue_.size();
    queue_.clear();
  }
  post_control([this, self, request_id, message] {
    LocalizerPtr previous;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      previous = std::move(localizer_);
      state_ = SessionState::kStopped;
      request_id_ = request_id;
      request_ok_ = true;
      message_ = message;
    }
    previous.reset();
    log(LogLevel::kInfo, "session stopped: " + message);
    publish_status();
  });
}

SessionStatusReport Session::status() const {
  SessionStatusReport s;
  std::lock_guard<std::mutex> lock(mutex_);
  s.robot_id = robot_id_;
  s.stamp_ns = wall_clock_ns();
  s.state = state_;
  s.plugin = plugin_;
  s.request_id = request_id_;
  s.request_ok = request_ok_;
  s.message = message_;
  s.last_error = last_error_;
  s.counters = counters_;
  s.initial_pose_stamp_ns = initial_pose_stamp_ns_;
  s.localization = localization_;
  return s;
}

void Session::publish_status() const {
  try {
    sink_.publish_status(status());
  } catch (const std::exception& e) {
    log(LogLevel::kError, std::string("status not published: ") + e.what());
  }
}

void Session::post_control(std::function<void()> work) {
  std::lock_guard<std::mutex> lock(mutex_);
  control_.push_back(std::move(work));
  schedule_drain_locked();
}

void Session::schedule_drain_locked() {
  if (drain_scheduled_) return;
  auto self = shared_from_this();
  drain_scheduled_ = pool_.post([self] { self->drain(); });
}

void Session::drain() {
  for (int handled = 0; handled < kDrainBatch; ++handled) {
    std::function<void()> control;
    std::optional<Measurement> next;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!control_.empty()) {
        control = std::move(control_.front());
        control_.pop_front();
      } else if (localizer_ && !stopped_ && !queue_.empty()) {
        next.emplace(std::move(queue_.front()));
        queue_.pop_front();
      } else {
        drain_scheduled_ = false;
        return;
      }
    }
    if (control) {
      control();
    } else {
      process(*next);
    }
  }
  // Yield the worker to other sessions; the strand stays scheduled.
  auto self = shared_from_this();
  if (!pool_.post([self] { self->drain(); })) {
    std::lock_guard<std::mutex> lock(mutex_);
    drain_scheduled_ = false;
  }
}

void Session::process(Measurement& measurement) {
  Localizer* localizer = localizer_.get();  // replaced only on this strand
  std::string plugin;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    plugin = plugin_;
  }
  const Header header = header_of(measurement);
  const char* topic = topic_of(kind_of(measurement));
  UpdateResult result;
  std::string error;
  const auto start = std::chrono::steady_clock::now();
  try {
    result = localizer->update(measurement);
  } catch (const InputError& e) {
    error = std::string(topic) + ": " + e.what();
  } catch (const std::exception& e) {
    error = "plugin '" + plugin + "' failed on " + topic + ": " + e.what();
  } catch (...) {
    error = "plugin '" + plugin + "' failed on " + topic + " with a non-standard exception";
  }
  const double update_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!error.empty()) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++counters_.rejected;
      last_error_ = error;
    }
    log_rejection(error);
    publish_status();
    return;
  }
  bool localization_changed = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.used;
    counters_.last_update_ms = update_ms;
    if (result.localization) {
      localization_changed = result.localization->state != localization_.state;
      localization_ = *result.localization;
    }
    if (result.estimate) {
      result.estimate->header.stamp_ns = header.stamp_ns;
      if (result.estimate->header.frame_id.empty()) result.estimate->header.frame_id = "map";
      ++counters_.updates;
      last_pose_ = *result.estimate;
    }
  }
  try {
    sink_.publish_outputs(robot_id_, plugin, map_header(header.stamp_ns), result, update_ms);
  } catch (const std::exception& e) {
    log(LogLevel::kError, std::string("outputs not published: ") + e.what());
  }
  if (localization_changed) {
    // A robot acts on "lost" at once, not at the next periodic status.
    log(LogLevel::kInfo, std::string("localization ") + localization_state_name(result.localization->state) + ": " +
                             result.localization->reason);
    publish_status();
  }
}

}  // namespace locd::server
