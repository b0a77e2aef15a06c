#include "locd/server/server.hpp"

#include <chrono>

#include "locd/dds/topics.hpp"
#include "locd/sdk/robot_id.hpp"

namespace locd::server {
namespace {

constexpr auto kNoSessionReportPeriod = std::chrono::seconds(1);
constexpr size_t kMaxUnservedRobots = 4096;  // bounds the memory a flood of robot ids can take

}  // namespace

namespace {

// Unclaimed resume states of the last run (robots that have not come back) are kept in the state
// file this long, so a server that restarts again soon loses none of them.
constexpr auto kKeepUnclaimedStatesFor = std::chrono::minutes(10);

worker::ConfigureRequest configure_template(const ServerConfig& config) {
  worker::ConfigureRequest request;
  request.limits = config.limits;
  for (const auto& dir : config.map_directories) request.map_directories.push_back(dir.string());
  request.output_directory = config.output_directory.string();
  return request;
}

}  // namespace

Server::Server(ServerConfig config, const PluginCatalog& catalog, OutputSink& sink, Logger& logger)
    : config_(std::move(config)), catalog_(catalog), sink_(sink), logger_(logger),
      pool_(static_cast<size_t>(config_.workers)), workers_(config_.plugin_workers, config_.limits, logger_),
      environment_{workers_, pool_, sink_, static_cast<size_t>(config_.queue_depth), config_.failures,
                   configure_template(config_), nullptr},
      state_file_(config_.state_directory), started_ns_(wall_clock_ns()), started_(std::chrono::steady_clock::now()) {
  pool_.on_task_error([this](const std::string& what) { logger_.log(LogLevel::kError, "server", "task failed: " + what); });
  environment_.forget = [this](const std::shared_ptr<Session>& session) {
    bool forgotten = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = sessions_.find(session->robot_id());
      if (it != sessions_.end() && it->second == session) {
        sessions_.erase(it);
        forgotten = true;
      }
    }
    if (forgotten && observer_) observer_->session_ended(session->robot_id());
  };
  saved_ = state_file_.load(logger_);
  if (state_file_.enabled()) {
    logger_.log(LogLevel::kInfo, "server",
                "state file " + state_file_.file().string() + ": " + std::to_string(saved_.size()) +
                    " robots to resume from their last pose");
  } else {
    logger_.log(LogLevel::kInfo, "server",
                "no state_directory: after a restart of this server, sessions start from the robots' initial poses");
  }
}

Server::~Server() { shutdown(); }

void Server::shutdown(std::chrono::milliseconds grace) {
  pool_.shutdown();
  workers_.shutdown(grace);
  std::map<std::string, std::shared_ptr<Session>> sessions;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    sessions.swap(sessions_);
  }
  sessions.clear();
}

void Server::save_state() {
  if (!state_file_.enabled()) return;
  std::map<std::string, ResumeState> states;
  std::vector<std::shared_ptr<Session>> sessions;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (std::chrono::steady_clock::now() - started_ < kKeepUnclaimedStatesFor) states = saved_;
    for (const auto& [_, session] : sessions_) sessions.push_back(session);
  }
  for (const auto& session : sessions) {
    if (auto state = session->resume_state()) states[session->robot_id()] = std::move(*state);
  }
  const std::string text = StateFile::encode(states);
  if (text == last_saved_) return;
  try {
    state_file_.write(text);
    last_saved_ = text;
  } catch (const std::exception& e) {
    logger_.log(LogLevel::kError, "server", std::string("state not saved: ") + e.what());
  }
}

ServerInfoReport Server::info() const {
  ServerInfoReport info;
  info.server_id = config_.server_id;
  info.started_ns = started_ns_;
  for (const auto& name : catalog_.names()) {
    const auto library = catalog_.find(name);
    const auto& d = library->descriptor();
    info.plugins.push_back({d.name, d.version ? d.version : "", d.description ? d.description : "",
                            kind_names(d.consumes)});
  }
  info.rejected_plugins = catalog_.rejected();
  return info;
}

void Server::boot() {
  try {
    sink_.publish_server_info(info());
  } catch (const std::exception& e) {
    logger_.log(LogLevel::kError, "server", std::string("server info not published: ") + e.what());
  }
  for (const auto& boot : config_.sessions) {
    std::shared_ptr<Session> session;
    uint64_t generation = 0;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      session = create_session_locked(boot.robot_id);
      generation = session->begin_request(0);
    }
    if (boot.initial_pose) {
      PoseEstimate pose;
      pose.header = {wall_clock_ns(), "map"};
      const auto& p = *boot.initial_pose;
      pose.pose = Eigen::Translation3d(p[0], p[1], 0.0) * Eigen::AngleAxisd(p[2], Eigen::Vector3d::UnitZ());
      session->set_pose(pose);
    }
    logger_.log(LogLevel::kInfo, boot.robot_id, "boot session: plugin " + boot.config.plugin + " from " + boot.source);
    start_plugin(session, generation, 0, boot.config.plugin, boot.text, boot.source);
  }
}

std::shared_ptr<Session> Server::create_session_locked(const std::string& robot_id) {
  auto& slot = sessions_[robot_id];
  if (!slot) {
    Logger* logger = &logger_;
    slot = std::make_shared<Session>(robot_id, environment_, [logger, robot_id](LogLevel level, const std::string& message) {
      logger->log(level, robot_id, message);
    });
    unserved_.erase(robot_id);
    if (auto saved = saved_.find(robot_id); saved != saved_.end()) {
      slot->seed(saved->second);
      saved_.erase(saved);
    }
  }
  return slot;
}

std::shared_ptr<Session> Server::find(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = sessions_.find(robot_id);
  return it == sessions_.end() ? nullptr : it->second;
}

uint64_t Server::messages_without_session() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return messages_without_session_;
}

void Server::on_session_request(SessionRequestMessage request) {
  if (const std::string error = robot_id_error(request.robot_id); !error.empty()) {
    on_invalid_robot_id(topics::kSessionRequest, "session request " + std::to_string(request.request_id) + ": " + error);
    return;
  }
  if (request.stop) {
    std::shared_ptr<Session> session;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = sessions_.find(request.robot_id);
      if (it != sessions_.end()) {
        session = it->second;
        sessions_.erase(it);
      }
    }
    if (session) {
      session->stop(request.request_id, "stopped by request " + std::to_string(request.request_id));
      if (observer_) observer_->session_ended(request.robot_id);
    } else {
      SessionStatusReport status;
      status.robot_id = request.robot_id;
      status.stamp_ns = wall_clock_ns();
      status.state = SessionState::kNoSession;
      status.request_id = request.request_id;
      status.request_ok = false;
      status.message = "no session to stop for robot '" + request.robot_id + "'";
      pool_.post([this, status] { sink_.publish_status(status); });
    }
    return;
  }
  std::shared_ptr<Session> session;
  uint64_t generation = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!sessions_.count(request.robot_id) && sessions_.size() >= config_.max_sessions) {
      SessionStatusReport status;
      status.robot_id = request.robot_id;
      status.stamp_ns = wall_clock_ns();
      status.state = SessionState::kNoSession;
      status.request_id = request.request_id;
      status.request_ok = false;
      status.message = "server '" + config_.server_id + "' already runs max_sessions = " +
                       std::to_string(config_.max_sessions) +
                       " sessions; stop one or raise max_sessions in the server config";
      logger_.log(LogLevel::kWarning, request.robot_id, status.message);
      pool_.post([this, status] { sink_.publish_status(status); });
      return;
    }
    session = create_session_locked(request.robot_id);
    generation = session->begin_request(request.request_id);
  }
  logger_.log(LogLevel::kInfo, request.robot_id, "session request " + std::to_string(request.request_id) +
                                                     (request.plugin.empty() ? "" : " for plugin " + request.plugin));
  pool_.post([this, session, generation, request = std::move(request)] { handle_start(session, generation, request); });
}

void Server::handle_start(const std::shared_ptr<Session>& session, uint64_t generation,
                          const SessionRequestMessage& request) {
  const std::string source =
      "session request " + std::to_string(request.request_id) + " for robot '" + request.robot_id + "'";
  PluginConfig config;
  try {
    if (!request.plugin.empty()) check_plugin_name(request.plugin, source);
    config = split_plugin_config(request.config_yaml, source);
    if (!request.plugin.empty() && request.plugin != config.plugin) {
      throw ConfigError(source + ": plugin '" + request.plugin + "' differs from the config's plugin '" +
                        config.plugin + "'; leave the request's plugin empty or make them equal");
    }
  } catch (const std::exception& e) {
    if (!session->fail_request(generation, request.request_id, e.what())) abandon_if_failed(session, generation);
    session->publish_status();
    return;
  }
  if (session->failed_before_restart(request.request_id)) {
    session->refuse_failed_request(request.request_id,
                                   source + ": its plugin failed max_failures = " +
                                       std::to_string(config_.failures.max_failures) +
                                       " times in a row before the server restarted; not started again (send a new "
                                       "request)");
    return;
  }
  start_plugin(session, generation, request.request_id, config.plugin, PluginConfigText{request.config_yaml, source, {}},
               source);
}

void Server::start_plugin(const std::shared_ptr<Session>& session, uint64_t generation, uint64_t request_id,
                          const std::string& plugin, const PluginConfigText& text, const std::string& source) {
  std::shared_ptr<const PluginLibrary> library;
  try {
    library = catalog_.require(plugin);
    // The parts kept beside the plugin (a robot's ROS 2 topics) follow the config before it is
    // sent to a worker; they may refuse it. (A switch that then fails in the worker keeps the
    // running plugin with the new config's ROS 2 topics.)
    if (observer_) observer_->session_configured(session->robot_id(), split_plugin_config(text));
  } catch (const std::exception& e) {
    if (!session->fail_request(generation, request_id, e.what())) abandon_if_failed(session, generation);
    session->publish_status();
    return;
  }
  session->start(generation, request_id, std::move(library), text, source);
}

void Server::abandon_if_failed(const std::shared_ptr<Session>& session, uint64_t generation) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = sessions_.find(session->robot_id());
    if (it == sessions_.end() || it->second != session || !session->abandon_if_idle(generation)) return;
    sessions_.erase(it);
  }
  if (observer_) observer_->session_ended(session->robot_id());
}

void Server::on_measurement(const std::string& robot_id, Measurement measurement) {
  const char* topic = topic_of(kind_of(measurement));
  if (auto session = find(robot_id); session && session->push(std::move(measurement))) return;
  report_no_session(robot_id, topic, "");
}

void Server::on_bad_input(const std::string& robot_id, const std::string& topic, const std::string& error) {
  const std::string message = "rejected message on " + topic + ": " + error;
  if (auto session = find(robot_id)) {
    session->reject_input(message);
    return;
  }
  report_no_session(robot_id, topic, " (it was malformed too: " + error + ")");
}

void Server::on_initial_pose(const std::string& robot_id, const PoseEstimate& pose) {
  if (auto session = find(robot_id)) {
    session->set_pose(pose);
    return;
  }
  report_no_session(robot_id, topics::kInitialPose, "");
}

void Server::on_map_save_request(const std::string& robot_id, uint64_t request_id) {
  if (auto session = find(robot_id)) {
    session->save_map(request_id);
    return;
  }
  report_no_session(robot_id, topics::kMapSaveRequest, "");
}

void Server::on_invalid_robot_id(const std::string& topic, const std::string& error) {
  std::string line;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++refused_robot_ids_;
    const auto now = std::chrono::steady_clock::now();
    if (now - last_refusal_log_ < kNoSessionReportPeriod) {
      ++refused_robot_ids_not_logged_;
      return;
    }
    last_refusal_log_ = now;
    line = "refused a message on " + topic + ": " + error;
    if (refused_robot_ids_not_logged_ > 0) {
      line += " (and " + std::to_string(refused_robot_ids_not_logged_) + " more refused since the last line)";
      refused_robot_ids_not_logged_ = 0;
    }
  }
  logger_.log(LogLevel::kWarning, "server", line);
}

uint64_t Server::messages_refused_for_robot_id() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return refused_robot_ids_;
}

void Server::report_no_session(const std::string& robot_id, const std::string& topic, const std::string& detail) {
  SessionStatusReport status;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++messages_without_session_;
    if (unserved_.size() >= kMaxUnservedRobots && !unserved_.count(robot_id)) unserved_.clear();
    auto& unserved = unserved_[robot_id];
    ++unserved.count;
    const auto now = std::chrono::steady_clock::now();
    if (unserved.reported && now - unserved.last_report < kNoSessionReportPeriod) return;
    unserved.reported = true;
    unserved.last_report = now;
    status.counters.received = unserved.count;
    status.counters.rejected = unserved.count;
  }
  status.robot_id = robot_id;
  status.stamp_ns = wall_clock_ns();
  status.state = SessionState::kNoSession;
  status.last_error = "no session for robot '" + robot_id + "': message on " + topic + " ignored" + detail +
                      "; send a session request on " + topics::kSessionRequest + " first";
  logger_.log(LogLevel::kWarning, robot_id.empty() ? "server" : robot_id, status.last_error);
  // Written on the pool: this runs on a listener thread, which must never block.
  pool_.post([this, status] { sink_.publish_status(status); });
}

void Server::publish_all_status() {
  std::vector<std::shared_ptr<Session>> sessions;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [_, s] : sessions_) sessions.push_back(s);
  }
  for (const auto& s : sessions) s->publish_status();
}

}  // namespace locd::server
