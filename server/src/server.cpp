#include "locd/server/server.hpp"

#include <algorithm>
#include <chrono>
#include <sstream>

#include "locd/dds/topics.hpp"
#include "locd/sdk/robot_id.hpp"

namespace locd::server {
namespace {

constexpr auto kNoSessionReportPeriod = std::chrono::seconds(1);
constexpr size_t kMaxUnservedRobots = 4096;  // bounds the memory a flood of robot ids can take
// Answers to dropped session requests: one a second per robot, 20 a second in all.
constexpr RequestRate kThrottleAnswersPerRobot{1.0, 1.0}, kThrottleAnswers{20.0, 20.0};

// Latest requests and other servers' resume states kept, whoever serves the robots.
constexpr size_t kMaxRequestsKept = 200000;
// Without news from the fleet, the rules are applied again this often.
constexpr auto kRebalanceEvery = std::chrono::seconds(1);
// A robot another server served is taken over only if heard from this recently, after the last
// server was found gone (a server cut off hears no robot), and heard without a break this long: a
// server whose network comes back after a cut hears the robots at once but the other servers
// only at their next heartbeat; in between it would think itself alone and take every robot.
constexpr auto kTakeoverHeardWithin = std::chrono::seconds(2);
constexpr auto kTakeoverHeardFor = std::chrono::seconds(1);
// Who is alive: every server writes its ServerInfo this often, and a server not heard from for
// kServerSilence is gone (killed, hung, or cut off). A heartbeat rather than a DDS liveliness
// lease: with Cyclone DDS 0.10, a writer whose lease lapsed (a cable cut for 5 s) stayed unseen
// by the cut-off side after the cable came back, which then thought itself alone.
constexpr auto kHeartbeatEvery = std::chrono::milliseconds(100);
constexpr auto kServerSilence = std::chrono::milliseconds(500);
// Other servers remembered at most (a flood of made-up server ids takes no more memory).
constexpr size_t kMaxServers = 1024;
// After a stall of this server, its outputs wait this long: it hears the other servers' heartbeats
// (every kHeartbeatEvery) and claims again, and hands back what was taken over meanwhile.
constexpr auto kRelistenAfterStall = std::chrono::milliseconds(1000);

int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

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

// What the server announces (built once: the config and the catalog do not change).
ServerInfoReport make_info(const ServerConfig& config, const PluginIndex& catalog, int64_t started_ns) {
  ServerInfoReport info;
  info.server_id = config.server_id;
  info.started_ns = started_ns;
  info.weight = config.weight;
  info.server_group = config.server_group;
  for (const auto& name : catalog.names()) {
    const auto d = catalog.find(name);
    info.plugins.push_back({d->name, d->version, d->description, kind_names(d->consumes)});
  }
  info.rejected_plugins = catalog.rejected();
  return info;
}

}  // namespace

Server::Server(ServerConfig config, const PluginIndex& catalog, OutputSink& sink, Logger& logger)
    : config_(std::move(config)), catalog_(catalog), sink_(sink), logger_(logger),
      pool_(static_cast<size_t>(config_.workers)), workers_(worker_settings(config_), config_.limits, logger_),
      environment_{workers_, pool_, sink_, static_cast<size_t>(config_.queue_depth), config_.failures,
                   configure_template(config_), nullptr},
      limiter_(config_.request_limits),
      source_limiter_(config_.request_limits.session_requests_per_participant),
      answers_per_robot_(kThrottleAnswersPerRobot),
      answers_(kThrottleAnswers),
      state_file_(config_.state_directory), started_ns_(wall_clock_ns()), started_(std::chrono::steady_clock::now()),
      fleet_(ServerMember{config_.server_id, config_.weight, config_.server_group}),
      info_(make_info(config_, catalog_, started_ns_)) {
  pool_.on_task_error([this](const std::string& what) { logger_.log(LogLevel::kError, "server", "task failed: " + what); });
  environment_.outputs_withheld = [this] { return outputs_withheld(); };
  environment_.forget = [this](const std::shared_ptr<Session>& session) {
    bool forgotten = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = sessions_.find(session->robot_id());
      if (it != sessions_.end() && it->second == session) {
        forget_locked(it);
        forgotten = true;
      }
    }
    publish_claims();
    if (forgotten && observer_) observer_->session_ended(session->robot_id());
  };
  saved_ = state_file_.load(logger_);
  for (const auto& [robot_id, state] : saved_) strongest_claim_[robot_id] = state.claim_strength;
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
  std::map<std::string, ResumeState> states;
  std::vector<std::shared_ptr<Session>> sessions;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (std::chrono::steady_clock::now() - started_ < kKeepUnclaimedStatesFor) states = saved_;
    for (const auto& [_, session] : sessions_) sessions.push_back(session);
  }
  for (const auto& session : sessions) {
    auto state = session->resume_state();
    if (!state) continue;
    state->server = config_.server_id;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto strength = strongest_claim_.find(session->robot_id());
      if (strength != strongest_claim_.end()) state->claim_strength = strength->second;
    }
    // To the other servers, when it changed: where the robot resumes should this server die.
    auto& shared = shared_[session->robot_id()];
    if (shared != std::make_pair(state->estimate.header.stamp_ns, state->failed)) {
      shared = {state->estimate.header.stamp_ns, state->failed};
      try {
        sink_.publish_resume_state(session->robot_id(), *state);
      } catch (const std::exception& e) {
        logger_.log(LogLevel::kError, session->robot_id(), std::string("resume state not shared: ") + e.what());
      }
    }
    states[session->robot_id()] = std::move(*state);
  }
  if (!state_file_.enabled()) return;
  const std::string text = StateFile::encode(states);
  if (text == last_saved_) return;
  try {
    state_file_.write(text);
    last_saved_ = text;
  } catch (const std::exception& e) {
    logger_.log(LogLevel::kError, "server", std::string("state not saved: ") + e.what());
  }
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
    publish_claims();
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
    // Where it resumes: this server's last run, or the server that served it before (whichever
    // saw the robot last).
    auto saved = saved_.find(robot_id);
    auto peer = peer_states_.find(robot_id);
    if (saved != saved_.end() && (peer == peer_states_.end() ||
                                  saved->second.estimate.header.stamp_ns >= peer->second.estimate.header.stamp_ns)) {
      slot->seed(saved->second);
    } else if (peer != peer_states_.end()) {
      slot->seed(peer->second);
      logger_.log(LogLevel::kInfo, robot_id, "taken over: resumes where server '" + peer->second.server + "' left it");
    }
    if (saved != saved_.end()) saved_.erase(saved);
    const auto known = strongest_claim_.find(robot_id);
    const int32_t strength =
        claim_strength(config_.server_id, known == strongest_claim_.end() ? 0 : known->second, wall_clock_ns());
    note_claim_strength_locked(robot_id, strength);
    fleet_.claim(robot_id, config_.server_id, true, wall_clock_ns(), strength);
    claims_to_publish_.push_back({robot_id, true, strength});
  }
  return slot;
}

void Server::note_claim_strength_locked(const std::string& robot_id, int32_t strength) {
  auto it = strongest_claim_.find(robot_id);
  if (it == strongest_claim_.end()) {
    if (strongest_claim_.size() >= kMaxRequestsKept) strongest_claim_.erase(strongest_claim_.begin());
    strongest_claim_.emplace(robot_id, strength);
  } else {
    it->second = std::max(it->second, strength);
  }
}

void Server::forget_locked(std::map<std::string, std::shared_ptr<Session>>::iterator it) {
  const std::string robot_id = it->first;
  sessions_.erase(it);
  fleet_.claim(robot_id, config_.server_id, false);
  claims_to_publish_.push_back({robot_id, false, 0});
  shared_.erase(robot_id);
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
  const std::string robot_id = request.robot_id;
  if (!admit(robot_id, RequestKind::kSessionRequest, "session request " + std::to_string(request.request_id),
             request.request_id, request.source)) {
    return;
  }
  if (request.stop) {
    std::shared_ptr<Session> session;
    bool answer = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      requests_.erase(robot_id);
      auto it = sessions_.find(robot_id);
      if (it != sessions_.end()) {
        session = it->second;
        forget_locked(it);
      } else {
        answer = fleet_.answers_for(robot_id, "");
      }
    }
    publish_claims();
    if (session) {
      session->stop(request.request_id, "stopped by request " + std::to_string(request.request_id));
      if (observer_) observer_->session_ended(robot_id);
    } else if (answer) {
      publish_refusal(robot_id, request.request_id, "no session to stop for robot '" + robot_id + "'");
    }
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!requests_.count(robot_id) && requests_.size() >= kMaxRequestsKept) {
      // Bounded: a flood of robot ids forgets the requests of robots served nowhere here first.
      for (auto it = requests_.begin(); it != requests_.end(); ++it) {
        if (!sessions_.count(it->first)) {
          requests_.erase(it);
          break;
        }
      }
    }
    StoredRequest& stored = requests_[robot_id];
    stored.request = std::move(request);
    stored.handled = false;  // every request delivered is acted on (a robot may send the same one again)
    stored.group.clear();
    try {
      stored.group = split_plugin_config(stored.request.config_yaml, "session request").server_group;
    } catch (const std::exception&) {
      // Refused where it is handled (the server that answers for the robot names the error).
    }
  }
  pool_.post([this, robot_id] { reconsider(robot_id); });
}

void Server::publish_claims() {
  // Serialised, in the order they were made; outside mutex_: a claim written reaches this
  // server's own claim reader on this thread, which takes mutex_.
  std::lock_guard<std::mutex> order(claims_mutex_);
  std::vector<ClaimChange> claims;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    claims.swap(claims_to_publish_);
  }
  for (const auto& claim : claims) {
    try {
      sink_.publish_claim(claim.robot_id, claim.serving, claim.strength);
    } catch (const std::exception& e) {
      logger_.log(LogLevel::kError, claim.robot_id, std::string("claim not published: ") + e.what());
    }
  }
}

bool Server::answers_for(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = requests_.find(robot_id);
  return fleet_.answers_for(robot_id, it == requests_.end() ? "" : it->second.group);
}

void Server::reconsider(const std::string& robot_id) {
  std::shared_ptr<Session> session, yielded;
  SessionRequestMessage request;
  uint64_t generation = 0;
  std::string handed_to;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto stored = requests_.find(robot_id);
    if (stored == requests_.end()) return;
    auto current = sessions_.find(robot_id);
    const bool serving = current != sessions_.end();
    const FleetView::Decision decision = fleet_.decide(robot_id, stored->second.group, serving);
    if (serving && decision == FleetView::Decision::kYield) {
      for (const auto& id : fleet_.claimants(robot_id)) {
        if (id != config_.server_id) handed_to = id;
      }
      yielded = current->second;
      forget_locked(current);
      stored->second.handled = false;  // should it come back here (its server died), it starts again
    } else if (!serving && decision != FleetView::Decision::kServe) {
      return;
    } else if (stored->second.handled && stored->second.handled_request_id == stored->second.request.request_id) {
      return;  // handled here already (served, refused, or failed): nothing new
    } else {
      if (!serving && served_elsewhere_.count(robot_id)) {
        // A takeover: only of a robot this server hears now (a server cut off from the network
        // takes nothing, and hands nothing back when it returns).
        const auto heard = last_heard_.find(robot_id);
        const auto now = std::chrono::steady_clock::now();
        if (heard == last_heard_.end() || now - heard->second.last > kTakeoverHeardWithin ||
            now - heard->second.since < kTakeoverHeardFor || heard->second.last < last_server_gone_) {
          fleet_changed_ = true;  // look again at the next tick
          return;
        }
      }
      request = stored->second.request;
      if (!serving && sessions_.size() >= config_.max_sessions) {
        const std::string message = "server '" + config_.server_id + "' already runs max_sessions = " +
                                    std::to_string(config_.max_sessions) +
                                    " sessions; stop one or raise max_sessions in the server config";
        logger_.log(LogLevel::kWarning, robot_id, message);
        stored->second.handled = true;
        stored->second.handled_request_id = request.request_id;
        publish_refusal(robot_id, request.request_id, message);
        return;
      }
      stored->second.handled = true;
      stored->second.handled_request_id = request.request_id;
      session = create_session_locked(robot_id);
      generation = session->begin_request(request.request_id);
    }
  }
  publish_claims();
  if (yielded) {
    yielded->stop(0, "handed over: server '" + handed_to + "' serves robot '" + robot_id +
                         "' too, since later (it took the robot over while this server was out of reach)");
    if (observer_) observer_->session_ended(robot_id);
    return;
  }
  logger_.log(LogLevel::kInfo, robot_id, "session request " + std::to_string(request.request_id) +
                                             (request.plugin.empty() ? "" : " for plugin " + request.plugin));
  handle_start(session, generation, request);
}

void Server::on_server_alive(const ServerMember& member) {
  bool joined = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (member.id == config_.server_id) return;
    if (server_heard_.size() >= kMaxServers && !server_heard_.count(member.id)) return;
    server_heard_[member.id] = std::chrono::steady_clock::now();
    const auto alive = fleet_.alive();
    const auto known = std::find_if(alive.begin(), alive.end(), [&](const ServerMember& m) { return m.id == member.id; });
    joined = known == alive.end();
    // Servers repeat their ServerInfo (kHeartbeatEvery); only news changes the fleet.
    if (!joined && known->weight == member.weight && known->group == member.group) return;
    fleet_.server_alive(member);
    fleet_changed_ = true;
  }
  if (joined) {
    // It may have missed (or dropped, cut off) this server's claims: tell it again.
    pool_.post([this] { sink_.republish_claims(); });
    logger_.log(LogLevel::kInfo, "server", "server '" + member.id + "' joined the fleet (weight " +
                                               std::to_string(member.weight) +
                                               (member.group.empty() ? "" : ", group " + member.group) + ")");
  }
}

void Server::on_server_gone(const std::string& server_id) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (server_id == config_.server_id || !server_heard_.erase(server_id)) return;
    forget_server_locked(server_id);
  }
  logger_.log(LogLevel::kInfo, "server", "server '" + server_id + "' is gone; its robots go to the servers left");
}

void Server::forget_server_locked(const std::string& server_id) {
  fleet_.server_gone(server_id);
  fleet_changed_ = true;
  last_server_gone_ = std::chrono::steady_clock::now();
}

void Server::on_claim(const std::string& robot_id, const std::string& server_id, bool serving, int64_t since_ns,
                      int32_t strength) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (server_id == config_.server_id) return;
  if (serving && served_elsewhere_.size() < kMaxRequestsKept) served_elsewhere_.insert(robot_id);
  if (serving) note_claim_strength_locked(robot_id, strength);
  fleet_.claim(robot_id, server_id, serving, since_ns, strength);
  fleet_changed_ = true;
}

void Server::on_peer_resume_state(const std::string& robot_id, const std::string& server_id, const ResumeState& state) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (server_id == config_.server_id) return;
  auto it = peer_states_.find(robot_id);
  if (it != peer_states_.end() && it->second.estimate.header.stamp_ns > state.estimate.header.stamp_ns) return;
  if (it == peer_states_.end() && peer_states_.size() >= kMaxRequestsKept) return;
  peer_states_[robot_id] = state;
}

bool Server::outputs_withheld() const {
  const int64_t now = steady_ns();
  const int64_t last_tick = last_tick_ns_.load();
  const bool stalled = others_known_.load() && last_tick != 0 &&
                       now - last_tick > std::chrono::nanoseconds(kServerSilence).count();
  if (!stalled && now >= withheld_until_ns_.load()) return false;
  ++outputs_withheld_count_;
  return true;
}

void Server::rebalance() {
  std::vector<std::string> robots;
  std::vector<std::string> silent;  // servers gone quiet
  bool announce = false;
  bool stalled = false;
  {
    const int64_t tick = steady_ns();
    const int64_t last_tick = last_tick_ns_.exchange(tick);
    const int64_t stall_ns = last_tick == 0 ? 0 : tick - last_tick;
    stalled = stall_ns > std::chrono::nanoseconds(kServerSilence).count();
    if (others_known_.load() && stalled) {
      withheld_until_ns_ = tick + std::chrono::nanoseconds(kRelistenAfterStall).count();
      logger_.log(LogLevel::kWarning, "server",
                  "this server was stalled for " + std::to_string(stall_ns / 1'000'000) +
                      " ms (its heartbeat could not go out): other servers may have taken its robots over; its "
                      "outputs are withheld for " + std::to_string(kRelistenAfterStall.count()) +
                      " ms while it hears the fleet again");
    } else if (withheld_until_ns_.load() != 0 && tick >= withheld_until_ns_.load()) {
      withheld_until_ns_ = 0;
      logger_.log(LogLevel::kInfo, "server",
                  "outputs published again; " + std::to_string(outputs_withheld_count_.exchange(0)) +
                      " were withheld after the stall");
    }
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto now = std::chrono::steady_clock::now();
    if (now - last_announce_ >= kHeartbeatEvery) {
      announce = true;
      last_announce_ = now;
    }
    for (auto it = server_heard_.begin(); it != server_heard_.end();) {
      // Not listening while stalled: the others' silence meanwhile says nothing of them.
      if (stalled) it->second = now;
      if (now - it->second <= kServerSilence) {
        ++it;
        continue;
      }
      silent.push_back(it->first);
      forget_server_locked(it->first);
      it = server_heard_.erase(it);
    }
    others_known_ = !server_heard_.empty();
    if (fleet_changed_ || now - last_rebalance_ >= kRebalanceEvery) {
      fleet_changed_ = false;
      last_rebalance_ = now;
      for (const auto& [robot_id, stored] : requests_) {
        const bool serving = sessions_.count(robot_id) > 0;
        const FleetView::Decision d = fleet_.decide(robot_id, stored.group, serving);
        if ((serving && d == FleetView::Decision::kYield) || (!serving && d == FleetView::Decision::kServe)) {
          robots.push_back(robot_id);
        }
      }
    }
  }
  for (const auto& id : silent) {
    logger_.log(LogLevel::kInfo, "server", "server '" + id + "' went silent (no ServerInfo for " +
                                               std::to_string(kServerSilence.count()) +
                                               " ms): gone; its robots go to the servers left");
  }
  for (const auto& robot_id : robots) pool_.post([this, robot_id] { reconsider(robot_id); });
  if (announce) {
    try {
      sink_.publish_server_info(info());
    } catch (const std::exception& e) {
      logger_.log(LogLevel::kError, "server", std::string("server info not published: ") + e.what());
    }
  }
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
  std::shared_ptr<const PluginDescription> description;
  try {
    description = catalog_.require(plugin);
    // The parts kept beside the plugin (a robot's ROS 2 topics) follow the config before it is
    // sent to a worker; they may refuse it. (A switch that then fails in the worker keeps the
    // running plugin with the new config's ROS 2 topics.)
    if (observer_) observer_->session_configured(session->robot_id(), split_plugin_config(text));
  } catch (const std::exception& e) {
    if (!session->fail_request(generation, request_id, e.what())) abandon_if_failed(session, generation);
    session->publish_status();
    return;
  }
  session->start(generation, request_id, std::move(description), text, source);
}

void Server::abandon_if_failed(const std::shared_ptr<Session>& session, uint64_t generation) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = sessions_.find(session->robot_id());
    if (it == sessions_.end() || it->second != session || !session->abandon_if_idle(generation)) return;
    forget_locked(it);
  }
  publish_claims();
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

void Server::on_output_problem(const std::string& robot_id, const std::string& problem) {
  if (auto session = find(robot_id)) session->report_output_problem(problem);
}

void Server::on_initial_pose(const std::string& robot_id, const PoseEstimate& pose) {
  if (!admit(robot_id, RequestKind::kInitialPose, "initial pose")) return;
  if (auto session = find(robot_id)) {
    session->set_pose(pose);
    return;
  }
  report_no_session(robot_id, topics::kInitialPose, "");
}

void Server::on_map_save_request(const std::string& robot_id, uint64_t request_id) {
  if (!admit(robot_id, RequestKind::kMapSave, "map save request " + std::to_string(request_id))) return;
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

bool Server::admit(const std::string& robot_id, RequestKind kind, const std::string& what, uint64_t request_id,
                   const std::string& source) {
  const bool robot_ok = limiter_.admit(robot_id, kind);
  // A writer naming many robots: its session requests across all of them.
  const bool source_ok = !robot_ok || kind != RequestKind::kSessionRequest || source.empty() ||
                         source_limiter_.admit(source, RequestKind::kSessionRequest);
  if (robot_ok && source_ok) return true;
  auto number = [](double v) {
    std::ostringstream out;
    out << v;
    return out.str();
  };
  const RequestRate& rate = robot_ok ? config_.request_limits.session_requests_per_participant
                                     : config_.request_limits.of(kind);
  const std::string limit = number(rate.per_s) + " a second (burst " + number(rate.burst) + ")";
  const std::string message =
      what + " of robot '" + robot_id + "' dropped: " +
      (robot_ok ? "its writer's participant " + source + " is over its limit of " + limit +
                      " across the robots it names, request_limits.session_requests_per_participant"
                : "over the robot's limit of " + limit + ", " + request_limit_key(kind)) +
      " in the server config";
  std::shared_ptr<Session> session;
  bool answer = false;  // a session request dropped is answered: once a second per robot, 20 in all
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++throttled_;
    if (auto it = sessions_.find(robot_id); it != sessions_.end()) session = it->second;
    if (kind == RequestKind::kSessionRequest && answers_per_robot_.admit(robot_id, kind) && answers_.admit("", kind)) {
      const auto stored = requests_.find(robot_id);
      answer = session || fleet_.answers_for(robot_id, stored == requests_.end() ? "" : stored->second.group);
    }
  }
  if (session) {
    session->throttle(message);  // on its status; the log has one line a second for every robot
    if (answer) {
      // The request's own answer, so the robot need not wait out its timeout; the session's
      // next status carries its last request handled again.
      SessionStatusReport status = session->status();
      status.request_id = request_id;
      status.request_ok = false;
      status.message = message;
      pool_.post([this, status] { sink_.publish_status(status); });
    }
  } else if (answer) {
    publish_refusal(robot_id, request_id, message);
  }
  std::string line;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto now = std::chrono::steady_clock::now();
    if (now - last_throttle_log_ < kNoSessionReportPeriod) {
      ++throttled_not_logged_;
      return false;
    }
    last_throttle_log_ = now;
    line = message;
    if (throttled_not_logged_ > 0) {
      line += " (and " + std::to_string(throttled_not_logged_) + " more dropped since the last line)";
      throttled_not_logged_ = 0;
    }
  }
  logger_.log(LogLevel::kWarning, robot_id, line);
  return false;
}

uint64_t Server::requests_throttled() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return throttled_;
}

uint64_t Server::messages_refused_for_robot_id() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return refused_robot_ids_;
}

void Server::publish_refusal(const std::string& robot_id, uint64_t request_id, std::string message) {
  SessionStatusReport status;
  status.robot_id = robot_id;
  status.stamp_ns = wall_clock_ns();
  status.state = SessionState::kNoSession;
  status.request_id = request_id;
  status.request_ok = false;
  status.message = std::move(message);
  pool_.post([this, status] { sink_.publish_status(status); });
}

void Server::report_no_session(const std::string& robot_id, const std::string& topic, const std::string& detail) {
  SessionStatusReport status;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (served_elsewhere_.count(robot_id)) {
      const auto now = std::chrono::steady_clock::now();
      Heard& heard = last_heard_[robot_id];
      if (now - heard.last > kTakeoverHeardWithin) heard.since = now;  // heard again after a break
      heard.last = now;
    }
    const auto stored = requests_.find(robot_id);
    if (!fleet_.answers_for(robot_id, stored == requests_.end() ? "" : stored->second.group)) {
      ++messages_served_elsewhere_;  // another server serves the robot (or will): not ours to answer
      return;
    }
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
