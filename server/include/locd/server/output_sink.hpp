// Where sessions and the server publish. The DDS bridge implements it for real; tests record.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "locd/sdk/types.hpp"
#include "locd/server/resume.hpp"

namespace locd::server {

// kRestarting: the plugin failed and is being restarted from the robot's last pose; kFailed: it
// failed max_failures times and was stopped.
enum class SessionState { kStarting, kRunning, kStopped, kError, kNoSession, kRestarting, kFailed };
const char* session_state_name(SessionState state);

struct SessionCounters {
  uint64_t received = 0;  // messages that arrived for the session (good or bad)
  uint64_t used = 0;      // measurements the plugin accepted
  uint64_t dropped = 0;   // messages dropped because the queue was full (oldest sensor frame first), or discarded
                          // unprocessed when the session ended or its first plugin failed
  uint64_t rejected = 0;  // bad input: conversion, stamps going backwards, plugin InputError
  uint64_t updates = 0;   // estimates published
  uint64_t lost = 0;      // lost in transit: gaps in the sequence numbers of a sensor stream
  std::array<uint64_t, 6> lost_by_kind{};  // the same per measurement kind (variant index)
  double last_update_ms = 0.0;  // plugin compute time of the last update
  // Messages taken and not yet used, dropped or rejected (queued, or with the plugin): always
  // received = used + dropped + rejected + held.
  uint64_t held = 0;
  // Session requests, initial poses and map saves dropped over the robot's rate limit
  // (request_limits); not counted in received.
  uint64_t throttled = 0;
};

struct SessionStatusReport {
  std::string robot_id;
  int64_t stamp_ns = 0;  // wall clock when made
  SessionState state = SessionState::kStarting;
  std::string plugin;
  uint64_t request_id = 0;
  bool request_ok = false;
  std::string message;     // outcome of the last request
  std::string last_error;  // last rejected input or failure
  SessionCounters counters;
  int64_t initial_pose_stamp_ns = 0;  // stamp of the last initial pose the plugin holds (0 = none)
  uint32_t failures = 0;              // plugin failures (crash, exit, hang, bad output)
  LocalizationAssessment localization;  // from the plugin's last update that judged it
  std::string waiting_for;  // what the held messages wait for (empty when none is held)
};

struct ServerInfoReport {
  struct Plugin {
    std::string name, version, description;
    std::vector<std::string> consumes;
  };
  std::string server_id;
  int64_t started_ns = 0;
  double weight = 1.0;       // rendezvous weight among the fleet's servers
  std::string server_group;  // robots asking for this group are served by its servers only
  std::vector<Plugin> plugins;
  std::vector<std::string> rejected_plugins;
};

class OutputSink {
 public:
  virtual ~OutputSink() = default;
  virtual void publish_status(const SessionStatusReport& status) = 0;
  // One update's outputs; `header` is the measurement's (pose stamp = measurement stamp).
  virtual void publish_outputs(const std::string& robot_id, const std::string& plugin, const Header& header,
                               const UpdateResult& result, double update_ms) = 0;
  virtual void publish_server_info(const ServerInfoReport& info) = 0;
  // To the fleet's other servers (default: a lone server, nothing to tell). A claim is written
  // while this server serves the robot and withdrawn when it stops; a resume state is where the
  // robot would resume on another server. The claim's strength (fleet.hpp) is also the
  // ownership strength of the robot's outputs: they are published only while claimed.
  virtual void publish_claim(const std::string& robot_id, bool serving, int32_t strength) {}
  // Writes every claim this server holds again, each with the time it was first made: a server
  // that joins, or comes back after its network was cut (it had dropped the claims it could not
  // hear), learns them; a double claim is then settled for the newest as usual.
  virtual void republish_claims() {}
  virtual void publish_resume_state(const std::string& robot_id, const ResumeState& state) {}
};

int64_t wall_clock_ns();

}  // namespace locd::server
