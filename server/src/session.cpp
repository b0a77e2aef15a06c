#include "locd/server/session.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "locd/dds/topics.hpp"
#include "locd/sdk/validate.hpp"

namespace locd::server {
namespace {

using Clock = std::chrono::steady_clock;

Header map_header(int64_t stamp_ns) { return {stamp_ns, "map"}; }

std::string stamp_text(int64_t stamp_ns) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(6);
  out << static_cast<double>(stamp_ns) * 1e-9 << " s";
  return out.str();
}

std::string seconds_text(double s) {
  std::ostringstream out;
  out << s << " s";
  return out.str();
}

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

Session::Session(std::string robot_id, SessionEnvironment& environment, SessionLog log)
    : robot_id_(std::move(robot_id)), env_(environment), log_(std::move(log)) {}

void Session::log(LogLevel level, const std::string& message) const {
  if (log_) log_(level, message);
}

void Session::log_rejection(const std::string& error) {
  std::string line;
  {
    std::lock_guard<std::mutex> lock(rejection_log_mutex_);
    const auto now = Clock::now();
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

// ------------------------------------------------------------------------------- input

bool Session::push(Measurement measurement) {
  const size_t kind_index = measurement.index();
  const int64_t stamp = header_of(measurement).stamp_ns;
  const uint64_t sequence = header_of(measurement).sequence;
  std::string error;
  const char* dropped = nullptr;  // topic of the message dropped from a full queue
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopped_) return false;
    ++counters_.received;
    // Loss in transit: a gap in the stream's numbers. A number not above the last one is a new
    // writer (the robot restarted) and starts the count again.
    if (sequence != 0) {
      uint64_t& last_sequence = last_sequence_[kind_index];
      if (last_sequence != 0 && sequence > last_sequence + 1) {
        counters_.lost += sequence - last_sequence - 1;
        counters_.lost_by_kind[kind_index] += sequence - last_sequence - 1;
      }
      last_sequence = sequence;
    }
    auto& last = last_stamp_[kind_index];
    if (last && stamp < *last) {
      ++counters_.rejected;
      error = std::string("stamp going backwards on ") + topic_of(kind_of(measurement)) + ": " +
              std::to_string(stamp) + " < " + std::to_string(*last) + " ns";
      last_error_ = error;
    } else {
      last = stamp;
      if (const auto* odometry = std::get_if<Odometry>(&measurement)) newest_odometry_ = *odometry;
      auto position = std::upper_bound(queue_.begin(), queue_.end(), stamp, [](int64_t s, const Measurement& m) {
        return s < header_of(m).stamp_ns;
      });
      queue_.insert(position, std::move(measurement));
      if (queue_.size() > std::max<size_t>(1, env_.queue_depth)) {
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
      pump_locked();
    }
  }
  if (!error.empty()) {
    log_rejection(error);
    publish_status_later();
  } else if (dropped) {
    log(LogLevel::kDebug, "queue full (" + std::to_string(env_.queue_depth) + "): dropped the oldest message on " + dropped);
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

void Session::throttle(const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.throttled;
    last_error_ = message;
  }
  publish_status_later();
}

void Session::report_output_problem(const std::string& problem) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_error_ = problem;
  }
  log(LogLevel::kWarning, problem);
  publish_status_later();
}

void Session::publish_status_later() {
  if (status_pending_.exchange(true)) return;
  auto self = shared_from_this();
  env_.pool.post([self] {
    self->status_pending_ = false;  // before reading: a later rejection schedules another status
    self->publish_status();
  });
}

void Session::set_pose(const PoseEstimate& pose) {
  Publication out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.received;
    if (seeded_ && pose.header.stamp_ns <= seeded_->estimate.header.stamp_ns) {
      // A transient-local replay of an initial pose older than where the robot was when the
      // server stopped: resuming from the newer pose is right.
      ++counters_.rejected;
      last_error_ = "initial pose stamped " + stamp_text(pose.header.stamp_ns) +
                    " is older than the pose resumed from the server's last run (stamped " +
                    stamp_text(seeded_->estimate.header.stamp_ns) + "); kept the resumed pose";
      out.log.emplace_back(LogLevel::kWarning, last_error_);
      out.status = true;
    } else {
      take_initial_pose_locked(pose, out);
    }
  }
  finish(out);
}

void Session::take_initial_pose_locked(const PoseEstimate& pose, Publication& out) {
  if (seeded_ || resume_from_seed_) {
    // Newer than the saved state: the robot says where it is now, and that wins.
    out.log.emplace_back(LogLevel::kInfo, "initial pose stamped " + stamp_text(pose.header.stamp_ns) +
                                              " is newer than the saved pose: the saved pose is not used");
    seeded_.reset();
    resume_from_seed_ = false;
  }
  // A resumed pose not yet handed to the plugin is superseded (it would otherwise wait for the
  // robot's next sensor message, which a robot may hold back until its initial pose is taken).
  control_.erase(std::remove_if(control_.begin(), control_.end(),
                                [](const Control& c) { return c.kind == Control::Kind::kResumePose; }),
                 control_.end());
  if (!plugin_alive_locked()) {
    // Handed to the plugin when it is installed; the robot's acknowledgement is the status
    // naming the pose's stamp (DDS orders samples per topic only).
    resume_ = ResumeState{pose, std::nullopt, current_ ? current_->name : "", request_id_, false};
    ++counters_.used;
    initial_pose_stamp_ns_ = pose.header.stamp_ns;
    out.log.emplace_back(LogLevel::kInfo, "initial pose kept for the plugin still starting");
    out.status = true;
  } else {
    control_.push_back({Control::Kind::kInitialPose, pose, 0});
    pump_locked();
  }
}

void Session::save_map(uint64_t request_id) {
  Publication out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!plugin_alive_locked()) {
      request_id_ = request_id;
      request_ok_ = false;
      message_ = "map save request " + std::to_string(request_id) + " refused: no plugin running";
      last_error_ = message_;
      out.log.emplace_back(LogLevel::kWarning, message_);
      out.status = true;
    } else {
      control_.push_back({Control::Kind::kSaveMap, {}, request_id});
      pump_locked();
    }
  }
  finish(out);
}

// ------------------------------------------------------------------------------- requests

uint64_t Session::begin_request(uint64_t request_id) {
  std::string dropped_seed;
  uint64_t generation = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // A request (re)starts the stream: a robot that restarted with its clock from zero is served.
    last_stamp_.fill(std::nullopt);
    // Another request than the one the saved state belongs to: the robot started again (or asks
    // anew), so the saved state no longer describes it. Its initial poses are its own, whatever
    // their stamps, and the plugin starts as the request says, not from the saved pose.
    if (seeded_ && seeded_->request_id != request_id) {
      dropped_seed = "the saved pose (request " + std::to_string(seeded_->request_id) +
                     ") is not used: request " + std::to_string(request_id) +
                     " is a new one (the robot started again or asked anew)";
      seeded_.reset();
      if (resume_from_seed_) resume_.reset();
      resume_from_seed_ = false;
    }
    generation = ++latest_generation_;
  }
  if (!dropped_seed.empty()) log(LogLevel::kInfo, dropped_seed);
  return generation;
}

void Session::start(uint64_t generation, uint64_t request_id, std::shared_ptr<const PluginDescription> plugin,
                    PluginConfigText config, const std::string& source) {
  Pending pending;
  pending.generation = generation;
  pending.plugin.name = plugin->name;
  pending.plugin.description = std::move(plugin);
  pending.plugin.config = std::move(config);
  pending.plugin.source = source;
  pending.plugin.request_id = request_id;
  configure_on_worker(std::move(pending));
}

void Session::configure_on_worker(Pending pending) {
  Publication out;
  uint64_t instance = 0;
  std::string error;
  try {
    instance = env_.workers.create_instance(pending.plugin.description, weak_from_this());
  } catch (const std::exception& e) {
    error = std::string("plugin '") + pending.plugin.name + "' could not be started: " + e.what();
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopped_ || pending.generation != latest_generation_) {
      if (instance) out.release.push_back(instance);
    } else if (!error.empty()) {
      if (pending.restart) {
        register_failure_locked(error, out);
      } else {
        fail_pending_locked(pending.plugin.request_id, error, out);
      }
    } else {
      if (pending_) out.release.push_back(pending_->plugin.instance);  // an older one still configuring
      pending.plugin.instance = instance;
      worker::ConfigureRequest request = env_.configure_template;
      request.robot_id = robot_id_;
      request.config = pending.plugin.config;
      pending_ = std::move(pending);
      // If the worker is already gone, its loss reaches on_lost and is handled there.
      env_.workers.configure(instance, request,
                             "configure of plugin '" + pending_->plugin.name + "' for robot '" + robot_id_ + "'");
    }
  }
  finish(out);
}

bool Session::fail_request(uint64_t generation, uint64_t request_id, const std::string& error) {
  bool running = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    running = plugin_alive_locked();
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
  if (generation != latest_generation_ || plugin_alive_locked() || pending_) return false;
  stopped_ = true;
  counters_.dropped += queue_.size();
  queue_.clear();
  return true;
}

void Session::stop(uint64_t request_id, const std::string& message) {
  Publication out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopped_ = true;
    ++latest_generation_;  // a plugin still being configured is never installed
    counters_.dropped += held_locked();
    queue_.clear();
    control_.clear();
    in_flight_.reset();
    if (plugin_alive_locked()) out.release.push_back(current_->instance);
    if (pending_) out.release.push_back(pending_->plugin.instance);
    if (release_after_reply_) out.release.push_back(*release_after_reply_);
    release_after_reply_.reset();
    current_.reset();
    pending_.reset();
    state_ = SessionState::kStopped;
    request_id_ = request_id;
    request_ok_ = true;
    message_ = message;
    out.log.emplace_back(LogLevel::kInfo, "session stopped: " + message);
    out.status = true;
  }
  finish(out);
}

void Session::seed(const ResumeState& state) {
  std::lock_guard<std::mutex> lock(mutex_);
  seeded_ = state;
  if (state.failed) {
    failed_request_id_ = state.request_id;
  } else {
    resume_ = state;
    resume_from_seed_ = true;
  }
}

bool Session::failed_before_restart(uint64_t request_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return seeded_ && seeded_->failed && seeded_->request_id == request_id;
}

void Session::refuse_failed_request(uint64_t request_id, const std::string& error) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    state_ = SessionState::kFailed;
    failed_request_id_ = request_id;
    request_id_ = request_id;
    request_ok_ = false;
    message_ = last_error_ = error;
  }
  log(LogLevel::kWarning, error);
  publish_status();
}

std::optional<ResumeState> Session::resume_state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_ == SessionState::kFailed && failed_request_id_) {
    ResumeState failed = resume_.value_or(ResumeState{});
    failed.request_id = *failed_request_id_;
    failed.plugin = current_ ? current_->name : failed.plugin;
    failed.failed = true;
    return failed;
  }
  return resume_;
}

// ------------------------------------------------------------------------------- the worker's turn

PoseEstimate Session::pose_at_next_message_locked() const {
  const Measurement& next = queue_.front();
  // An odometry message: the plugin takes it as its reference, so the pose is exact there.
  if (const auto* odometry = std::get_if<Odometry>(&next)) return resume_pose(*resume_, odometry);
  // Another kind: the newest odometry, carried on to that message's stamp by its velocity.
  if (newest_odometry_) {
    const int64_t stamp = header_of(next).stamp_ns;
    if (const auto odom = odometry_at(*newest_odometry_, stamp)) {
      Odometry at_stamp = *newest_odometry_;
      at_stamp.header.stamp_ns = stamp;
      at_stamp.pose = *odom;
      return resume_pose(*resume_, &at_stamp);
    }
  }
  return resume_pose(*resume_, nullptr);
}

void Session::pump_locked() {
  if (in_flight_ || !plugin_alive_locked() || stopped_) return;
  const uint64_t instance = current_->instance;
  InFlight next;
  next.instance = instance;
  next.plugin = current_->name;
  if (!control_.empty()) {
    auto next_control = control_.begin();
    if (next_control->kind == Control::Kind::kResumePose && queue_.empty()) {
      // The resumed pose waits for the robot's next message (below); what stands behind it
      // (a map save) does not wait with it.
      next_control = std::find_if(control_.begin(), control_.end(),
                                  [](const Control& c) { return c.kind != Control::Kind::kResumePose; });
      if (next_control == control_.end()) next_control = control_.begin();
    }
    Control control = std::move(*next_control);
    control_.erase(next_control);
    switch (control.kind) {
      case Control::Kind::kSaveMap:
        next.what = "map save request " + std::to_string(control.request_id);
        break;
      case Control::Kind::kResumePose:
        if (!resume_) return;
        if (queue_.empty()) {
          // The pose is placed where the robot is at the next message: wait for it.
          control_.push_front(std::move(control));
          return;
        }
        control.pose = pose_at_next_message_locked();
        [[fallthrough]];
      case Control::Kind::kInitialPose:
        next.what = std::string(control.kind == Control::Kind::kInitialPose ? "initial pose" : "resumed pose") +
                    " stamped " + stamp_text(control.pose.header.stamp_ns);
        break;
    }
    next.control = std::move(control);
  } else if (!queue_.empty()) {
    next.measurement.emplace(std::move(queue_.front()));
    queue_.pop_front();
    next.what = std::string("update of ") + topic_of(kind_of(*next.measurement)) + " stamped " +
                stamp_text(header_of(*next.measurement).stamp_ns);
    if (const auto* odometry = std::get_if<Odometry>(&*next.measurement)) last_odometry_sent_ = *odometry;
  } else {
    return;
  }
  in_flight_ = std::move(next);
  // If the worker is gone, on_lost puts the request back or drops it.
  const InFlight& f = *in_flight_;
  if (f.measurement) {
    env_.workers.update(instance, *f.measurement, f.what);
  } else if (f.control->kind == Control::Kind::kSaveMap) {
    env_.workers.save_map(instance, f.what);
  } else {
    env_.workers.set_pose(instance, f.control->pose, f.what);
  }
}

void Session::on_reply(uint64_t instance, worker::Reply reply) {
  Publication out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (pending_ && pending_->plugin.instance == instance && reply.request == worker::Op::kConfigure) {
      Pending pending = std::move(*pending_);
      pending_.reset();
      handle_configured_locked(std::move(pending), reply, out);
    } else if (in_flight_ && in_flight_->instance == instance) {
      InFlight done = std::move(*in_flight_);
      in_flight_.reset();
      if (done.measurement) {
        handle_update_locked(done, reply, out);
      } else {
        handle_control_locked(done, reply, out);
      }
      if (release_after_reply_ == done.instance) {
        out.release.push_back(done.instance);
        release_after_reply_.reset();
      }
      if (failures_in_a_row_ > 0 &&
          Clock::now() - running_since_ > std::chrono::duration<double>(env_.failures.failure_reset_s)) {
        failures_in_a_row_ = 0;
      }
    }
    pump_locked();
  }
  finish(out);
}

void Session::handle_configured_locked(Pending pending, worker::Reply& reply, Publication& out) {
  const std::string plugin = pending.plugin.name;
  if (stopped_ || pending.generation != latest_generation_) {
    out.release.push_back(pending.plugin.instance);
    out.log.emplace_back(LogLevel::kInfo, "request " + std::to_string(pending.plugin.request_id) + " for plugin " +
                                              plugin + " superseded by a newer request; not installed");
    return;
  }
  if (reply.outcome != worker::Outcome::kOk) {
    out.release.push_back(pending.plugin.instance);
    if (pending.restart) {
      register_failure_locked("plugin '" + plugin + "' could not be restarted: " + reply.message, out);
      return;
    }
    fail_pending_locked(pending.plugin.request_id, reply.message, out);
    return;
  }
  const std::string previous = current_ ? current_->name : "";
  if (plugin_alive_locked()) {
    // The old plugin finishes the request it is handling (its outputs are published), then goes.
    if (in_flight_ && in_flight_->instance == current_->instance) {
      release_after_reply_ = current_->instance;
    } else {
      out.release.push_back(current_->instance);
    }
  }
  current_ = std::move(pending.plugin);
  state_ = SessionState::kRunning;
  running_since_ = Clock::now();
  if (pending.restart) {
    message_ = "plugin " + plugin + " restarted after failure " + std::to_string(failures_) +
               (resume_ ? " (resumed from the robot's last pose)" : "");
    out.log.emplace_back(LogLevel::kInfo, message_);
  } else {
    failures_in_a_row_ = 0;
    failed_request_id_.reset();
    request_id_ = current_->request_id;
    request_ok_ = true;
    message_ = "plugin " + plugin + " " + current_->description->version + " configured from " + current_->source;
    if (previous.empty()) {
      out.log.emplace_back(LogLevel::kInfo, "session started: plugin " + plugin);
    } else {
      out.log.emplace_back(LogLevel::kInfo, "switched plugin " + previous + " -> " + plugin +
                                                (resume_ ? " (last pose handed over)" : " (no pose to hand over yet)"));
    }
  }
  if (resume_) control_.push_front({Control::Kind::kResumePose, {}, 0});
  out.outputs = std::move(reply.result);
  out.plugin = plugin;
  out.header = map_header(wall_clock_ns());
  out.status = true;
}

void Session::handle_update_locked(InFlight& done, worker::Reply& reply, Publication& out) {
  const Header header = header_of(*done.measurement);
  const char* topic = topic_of(kind_of(*done.measurement));
  std::string error;
  if (reply.outcome == worker::Outcome::kInputError) {
    error = std::string(topic) + ": " + reply.message;
  } else if (reply.outcome != worker::Outcome::kOk) {
    error = "plugin '" + done.plugin + "' failed on " + topic + ": " + reply.message;
  } else if (reply.result.estimate) {
    auto& estimate = *reply.result.estimate;
    estimate.header.stamp_ns = header.stamp_ns;
    if (estimate.header.frame_id.empty()) estimate.header.frame_id = "map";
    try {
      validate(estimate);
    } catch (const InputError& e) {
      error = "plugin '" + done.plugin + "' returned an unusable estimate for the " + done.what + ": " + e.what() +
              "; refused";
    }
  }
  if (!error.empty()) {
    ++counters_.rejected;
    last_error_ = error;
    out.log.emplace_back(LogLevel::kWarning, "rejected: " + error);
    out.status = true;
    return;
  }
  ++counters_.used;
  counters_.last_update_ms = reply.compute_ms;
  if (reply.result.localization) {
    if (reply.result.localization->state != localization_.state) {
      // A robot acts on "lost" at once, not at the next periodic status.
      out.status = true;
      out.log.emplace_back(LogLevel::kInfo, std::string("localization ") +
                                                localization_state_name(reply.result.localization->state) + ": " +
                                                reply.result.localization->reason);
    }
    localization_ = *reply.result.localization;
  }
  if (reply.result.estimate) {
    ++counters_.updates;
    const PoseEstimate& estimate = *reply.result.estimate;
    ResumeState state{estimate, std::nullopt, done.plugin, current_ ? current_->request_id : request_id_, false};
    if (last_odometry_sent_) state.map_from_odom = map_from_odom(estimate, *last_odometry_sent_);
    resume_ = std::move(state);
    resume_from_seed_ = false;
  }
  out.outputs = std::move(reply.result);
  out.plugin = done.plugin;
  out.header = map_header(header.stamp_ns);
  out.update_ms = reply.compute_ms;
  out.of_update = true;
}

void Session::handle_control_locked(InFlight& done, worker::Reply& reply, Publication& out) {
  const Control& control = *done.control;
  const bool ok = reply.outcome == worker::Outcome::kOk;
  switch (control.kind) {
    case Control::Kind::kInitialPose:
      if (ok) {
        ++counters_.used;
        initial_pose_stamp_ns_ = control.pose.header.stamp_ns;
        resume_ = ResumeState{control.pose, std::nullopt, done.plugin, request_id_, false};
        resume_from_seed_ = false;
        out.log.emplace_back(LogLevel::kInfo, "initial pose set: x " + std::to_string(control.pose.pose.translation().x()) +
                                                  ", y " + std::to_string(control.pose.pose.translation().y()));
      } else {
        ++counters_.rejected;
        last_error_ = "initial pose rejected by plugin '" + done.plugin + "': " + reply.message;
        out.log.emplace_back(LogLevel::kWarning, last_error_);
      }
      out.status = true;
      break;
    case Control::Kind::kResumePose:
      if (!ok) {
        last_error_ = "plugin '" + done.plugin + "' refused the handed-over pose: " + reply.message;
        out.log.emplace_back(LogLevel::kWarning, last_error_);
        out.status = true;
      }
      break;
    case Control::Kind::kSaveMap:
      request_id_ = control.request_id;
      request_ok_ = ok;
      message_ = ok ? "map saved to " + reply.message
                    : "map save request " + std::to_string(control.request_id) + " refused: " + reply.message;
      if (!ok) last_error_ = message_;
      out.log.emplace_back(ok ? LogLevel::kInfo : LogLevel::kWarning, message_);
      out.status = true;
      break;
  }
}

void Session::on_log(uint64_t, const worker::LogLine& line) { log(line.level, line.text); }

void Session::on_lost(uint64_t instance, const WorkerLoss& loss) {
  Publication out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (pending_ && pending_->plugin.instance == instance) {
      Pending pending = std::move(*pending_);
      pending_.reset();
      if (stopped_ || pending.generation != latest_generation_) {
        // superseded meanwhile: nothing to report
      } else if (pending.restart) {
        register_failure_locked(loss.description, out);
      } else {
        fail_pending_locked(pending.plugin.request_id, loss.description, out);
      }
    }
    if (release_after_reply_ == instance) release_after_reply_.reset();
    if (in_flight_ && in_flight_->instance == instance) {
      InFlight lost = std::move(*in_flight_);
      in_flight_.reset();
      if (loss.blamed) {
        // What the plugin died on is not given to it again.
        if (lost.measurement || (lost.control && lost.control->kind == Control::Kind::kInitialPose)) {
          ++counters_.rejected;
        }
      } else if (lost.measurement) {
        queue_.push_front(std::move(*lost.measurement));
      } else if (lost.control) {
        control_.push_front(std::move(*lost.control));
      }
    }
    if (current_ && current_->instance == instance) {
      current_->instance = 0;
      if (!stopped_) {
        if (loss.blamed) {
          register_failure_locked(loss.description, out);
        } else {
          state_ = SessionState::kRestarting;
          last_error_ = loss.description;
          out.log.emplace_back(LogLevel::kWarning, loss.description);
          out.status = true;
          schedule_restart_locked(std::chrono::duration<double>(0.0));
        }
      }
    }
    pump_locked();
  }
  finish(out);
}

void Session::fail_pending_locked(uint64_t request_id, const std::string& error, Publication& out) {
  // The running plugin (if any) carries on; a session left without one ends (its router forgets
  // it) and what it had queued is counted as dropped.
  const bool running = plugin_alive_locked();
  request_id_ = request_id;
  request_ok_ = false;
  message_ = last_error_ = error;
  if (!running) {
    state_ = SessionState::kError;
    stopped_ = true;
    counters_.dropped += queue_.size();
    queue_.clear();
    out.forget = true;
  }
  out.log.emplace_back(LogLevel::kWarning, "request " + std::to_string(request_id) + " failed" +
                                               (running ? " (the running plugin carries on): " : ": ") + error);
  out.status = true;
}

void Session::register_failure_locked(const std::string& description, Publication& out) {
  if (failures_in_a_row_ > 0 &&
      Clock::now() - running_since_ > std::chrono::duration<double>(env_.failures.failure_reset_s)) {
    failures_in_a_row_ = 0;
  }
  ++failures_;
  ++failures_in_a_row_;
  out.status = true;
  if (failures_in_a_row_ >= env_.failures.max_failures) {
    state_ = SessionState::kFailed;
    failed_request_id_ = current_ ? current_->request_id : request_id_;
    last_error_ = description + "; it failed " + std::to_string(failures_in_a_row_) +
                  " times in a row (max_failures = " + std::to_string(env_.failures.max_failures) +
                  "): stopped; a new session request starts it again";
    message_ = "plugin failed " + std::to_string(failures_in_a_row_) + " times in a row; session stopped";
    counters_.dropped += held_locked();
    queue_.clear();
    control_.clear();
    out.log.emplace_back(LogLevel::kError, last_error_);
    return;
  }
  const double delay = std::min(env_.failures.backoff_max_s,
                                env_.failures.backoff_initial_s * std::pow(2.0, failures_in_a_row_ - 1.0));
  state_ = SessionState::kRestarting;
  last_error_ = description + "; restart " + std::to_string(failures_in_a_row_) + " of at most " +
                std::to_string(env_.failures.max_failures - 1) + " in " + seconds_text(delay);
  out.log.emplace_back(LogLevel::kError, last_error_);
  schedule_restart_locked(std::chrono::duration<double>(delay));
}

void Session::schedule_restart_locked(std::chrono::duration<double> delay) {
  std::weak_ptr<Session> weak = weak_from_this();
  const uint64_t generation = latest_generation_;
  env_.workers.after(std::chrono::duration_cast<Clock::duration>(delay), [weak, generation] {
    if (auto self = weak.lock()) self->restart(generation);
  });
}

void Session::restart(uint64_t generation) {
  Pending pending;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopped_ || generation != latest_generation_ || !current_ || current_->instance != 0 || pending_ ||
        state_ == SessionState::kFailed) {
      return;
    }
    pending.plugin = *current_;
    pending.generation = generation;
    pending.restart = true;
  }
  configure_on_worker(std::move(pending));
}

void Session::finish(Publication& out) {
  for (const uint64_t instance : out.release) env_.workers.release(instance);
  for (const auto& [level, line] : out.log) log(level, line);
  if (out.outputs && out.of_update && env_.outputs_withheld && env_.outputs_withheld()) out.outputs.reset();
  if (out.outputs) {
    try {
      env_.sink.publish_outputs(robot_id_, out.plugin, out.header, *out.outputs, out.update_ms);
    } catch (const std::exception& e) {
      log(LogLevel::kError, std::string("outputs not published: ") + e.what());
    }
  }
  if (out.forget && env_.forget) env_.forget(shared_from_this());
  if (out.status) publish_status();
}

// ------------------------------------------------------------------------------- status

SessionStatusReport Session::status() const {
  SessionStatusReport s;
  std::lock_guard<std::mutex> lock(mutex_);
  s.robot_id = robot_id_;
  s.stamp_ns = wall_clock_ns();
  s.state = state_;
  s.plugin = current_ ? current_->name : "";
  s.request_id = request_id_;
  s.request_ok = request_ok_;
  s.message = message_;
  s.last_error = last_error_;
  s.counters = counters_;
  s.counters.held = held_locked();
  s.waiting_for = waiting_for_locked();
  s.initial_pose_stamp_ns = initial_pose_stamp_ns_;
  s.failures = failures_;
  s.localization = localization_;
  return s;
}

size_t Session::held_locked() const {
  size_t held = queue_.size();
  for (const Control& c : control_) held += c.kind == Control::Kind::kInitialPose;
  if (in_flight_ && (in_flight_->measurement ||
                     (in_flight_->control && in_flight_->control->kind == Control::Kind::kInitialPose))) {
    ++held;
  }
  return held;
}

std::string Session::waiting_for_locked() const {
  const bool map_save_held = std::any_of(control_.begin(), control_.end(),
                                         [](const Control& c) { return c.kind == Control::Kind::kSaveMap; });
  if (held_locked() == 0 && !map_save_held) return "";
  const std::string plugin = current_ ? current_->name : pending_ ? pending_->plugin.name : "";
  if (in_flight_) return "plugin '" + in_flight_->plugin + "' to answer the " + in_flight_->what;
  if (stopped_) return "nothing: the session has ended";
  if (pending_ && !plugin_alive_locked()) return "plugin '" + plugin + "' to be configured";
  if (state_ == SessionState::kRestarting) return "plugin '" + plugin + "' to restart after its failure";
  if (!plugin_alive_locked()) return "a plugin: none runs (send a session request)";
  if (!control_.empty() && control_.front().kind == Control::Kind::kResumePose && queue_.empty()) {
    return "the robot's next sensor message, to place the resumed pose where the robot is then";
  }
  return "its turn with plugin '" + plugin + "'";
}

void Session::publish_status() const {
  try {
    env_.sink.publish_status(status());
  } catch (const std::exception& e) {
    log(LogLevel::kError, std::string("status not published: ") + e.what());
  }
}

}  // namespace locd::server
