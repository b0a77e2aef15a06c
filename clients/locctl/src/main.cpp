// locctl: start, switch, stop and watch locd sessions from a shell. See `locctl --help`.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <cerrno>
#include <ctime>
#include <filesystem>
#include <deque>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>

#include "command_line.hpp"
#include "json.hpp"
#include "record.hpp"
#include "security.hpp"
#include "locd/client/client.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/text.hpp"

namespace locd::locctl {
namespace {

using std::chrono::milliseconds;
using Clock = std::chrono::steady_clock;

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

// A failure to report: locctl prints it (as {"ok":false,"error":...} with --json) and exits 1.
class Failure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

std::atomic<bool> interrupted{false};
void on_interrupt(int) { interrupted = true; }

milliseconds to_ms(double seconds) { return milliseconds(static_cast<int64_t>(std::llround(seconds * 1000.0))); }

std::string seconds_text(double s) {
  std::ostringstream out;
  out << s << " s";
  return out.str();
}

std::string no_server_message(const CommandLine& cl, double timeout_s) {
  const char* uri = std::getenv("CYCLONEDDS_URI");
  return "no locd server found on DDS domain " + std::to_string(cl.domain) + " within " + seconds_text(timeout_s) +
         " (CYCLONEDDS_URI=" + (uri && *uri ? std::string(uri) : std::string("unset: Cyclone's default interface")) +
         "); is locd running with the same domain and the same CYCLONEDDS_URI? (--domain N, --timeout S)";
}

// A client acting for `robot` (publishes in its partition and reads its outputs), or, with an
// empty robot, a watcher of `watch` (every robot by default).
ClientOptions client_options(const CommandLine& cl, const std::string& robot, std::vector<std::string> watch = {}) {
  ClientOptions o;
  o.domain_id = cl.domain;
  o.robot_id = robot;
  o.watch = std::move(watch);
  return o;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Failure("cannot read config file '" + path + "': " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Failure("cannot read config file '" + path + "'");
  return text.str();
}

Json lost_json(const SessionStatus& s) {
  Json out = Json::object();
  for (const auto& [topic, count] : s.lost_by_stream) out[topic] = count;
  return out;
}

Json status_json(const SessionStatus& s) {
  return {{"robot", s.robot_id},
          {"server", s.server_id},
          {"state", s.state},
          {"plugin", s.plugin},
          {"request_id", s.request_id},
          {"request_ok", s.request_ok},
          {"message", s.message},
          {"last_error", s.last_error},
          {"received", s.received},
          {"used", s.used},
          {"dropped", s.dropped},
          {"rejected", s.rejected},
          {"updates", s.updates},
          {"last_update_ms", s.last_update_ms},
          {"failures", s.failures},
          {"lost", s.lost},
          {"lost_by_stream", lost_json(s)},
          {"localization", s.localization},
          {"localization_reason", s.localization_reason},
          {"held", s.held},
          {"throttled", s.throttled},
          {"waiting_for", s.waiting_for},
          {"stamp_ns", s.stamp_ns}};
}

// Prints the answer to a session request (use, stop); exit 0 when the server accepted it.
int report_answer(const CommandLine& cl, const std::string& robot, const std::optional<SessionStatus>& answer,
                  double timeout_s, const std::vector<ServerInfo>& servers) {
  if (!answer) {
    std::string names;
    for (const auto& s : servers) names += (names.empty() ? "" : ", ") + s.server_id;
    throw Failure("no answer to the " + cl.command + " request for robot '" + robot + "' within " +
                  seconds_text(timeout_s) + " (servers seen: " + (names.empty() ? "none" : names) +
                  "); try a longer --timeout");
  }
  if (cl.json) {
    std::cout << Json{{"command", cl.command}, {"ok", answer->request_ok}, {"status", status_json(*answer)}}.dump()
              << "\n";
  } else {
    std::ostream& out = answer->request_ok ? std::cout : std::cerr;
    // Text from the network is escaped on a terminal too (JSON output escapes it anyway).
    out << robot << ": " << (answer->request_ok ? "ok" : "refused") << " by server " << escaped(answer->server_id)
        << " (state " << answer->state << (answer->plugin.empty() ? "" : ", plugin " + escaped(answer->plugin))
        << "): " << escaped(answer->message, 4096) << "\n";
  }
  return answer->request_ok ? 0 : kExitFailure;
}

int command_use(const CommandLine& cl) {
  const std::string& robot = cl.arguments[0];
  const std::string& file = cl.arguments[1];
  const double timeout_s = cl.timeout_s.value_or(10.0);
  const std::string text = read_file(file);
  PluginConfig config;
  try {
    config = split_plugin_config(text, file);
  } catch (const std::exception& e) {
    throw Failure(std::string("invalid plugin config: ") + e.what());
  }
  const auto deadline = Clock::now() + to_ms(timeout_s);
  Client client(client_options(cl, robot));
  if (!client.wait_for_server(to_ms(timeout_s))) throw Failure(no_server_message(cl, timeout_s));
  const auto left = std::chrono::duration_cast<milliseconds>(deadline - Clock::now());
  const auto answer = client.request_session(config.plugin, text, std::max(left, milliseconds(1)));
  return report_answer(cl, robot, answer, timeout_s, client.servers());
}

int command_stop(const CommandLine& cl) {
  const std::string& robot = cl.arguments[0];
  const double timeout_s = cl.timeout_s.value_or(10.0);
  const auto deadline = Clock::now() + to_ms(timeout_s);
  Client client(client_options(cl, robot));
  if (!client.wait_for_server(to_ms(timeout_s))) throw Failure(no_server_message(cl, timeout_s));
  const auto left = std::chrono::duration_cast<milliseconds>(deadline - Clock::now());
  const auto answer = client.stop_session(std::max(left, milliseconds(1)));
  return report_answer(cl, robot, answer, timeout_s, client.servers());
}

int command_initial_pose(const CommandLine& cl) {
  const std::string& robot = cl.arguments[0];
  const double x = std::stod(cl.arguments[1]), y = std::stod(cl.arguments[2]), yaw = std::stod(cl.arguments[3]);
  const double timeout_s = cl.timeout_s.value_or(5.0);
  Client client(client_options(cl, robot));
  if (!client.wait_for_server(to_ms(timeout_s))) throw Failure(no_server_message(cl, timeout_s));
  PoseEstimate pose;
  pose.header.stamp_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  pose.header.frame_id = "map";
  pose.pose = Eigen::Translation3d(x, y, 0.0) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
  pose.covariance = Matrix6d::Zero();
  pose.covariance(0, 0) = pose.covariance(1, 1) = cl.std_xy * cl.std_xy;
  pose.covariance(5, 5) = cl.std_yaw * cl.std_yaw;
  const auto held = client.set_initial_pose(pose, to_ms(timeout_s));
  if (!held) {
    throw Failure("the initial pose for robot '" + robot + "' was not taken within " + seconds_text(timeout_s) +
                  " (is a session running for it? locctl status " + robot + ")");
  }
  if (held->initial_pose_stamp_ns != pose.header.stamp_ns) throw Failure(held->last_error);
  if (cl.json) {
    std::cout << Json{{"command", "initial-pose"}, {"ok", true},       {"robot", robot},
                      {"x", x},                   {"y", y},          {"yaw", yaw},
                      {"std_xy", cl.std_xy},      {"std_yaw", cl.std_yaw}}
                     .dump()
              << "\n";
  } else {
    std::cout << robot << ": initial pose x=" << x << " y=" << y << " yaw=" << yaw << " rad held by plugin " << held->plugin << "\n";
  }
  return 0;
}

std::string pad(std::string text, size_t width) {
  if (text.size() < width) text.append(width - text.size(), ' ');
  return text;
}

int command_status(const CommandLine& cl) {
  const std::string robot = cl.arguments.empty() ? "" : cl.arguments[0];
  const double timeout_s = cl.timeout_s.value_or(2.0);
  Client client(client_options(cl, "", {robot.empty() ? "*" : robot}));
  // Transient-local statuses arrive right after discovery; wait for all of them until the
  // timeout, or only until the one robot asked for has reported.
  std::mutex mutex;
  std::condition_variable seen;
  bool robot_seen = false;
  if (!robot.empty()) {
    client.on_status(
        [&](const SessionStatus&) {
          std::lock_guard<std::mutex> lock(mutex);
          robot_seen = true;
          seen.notify_all();
        },
        robot);
  }
  {
    std::unique_lock<std::mutex> lock(mutex);
    seen.wait_for(lock, to_ms(timeout_s), [&] {
      if (robot.empty()) return false;
      for (const auto& s : client.statuses()) robot_seen = robot_seen || s.robot_id == robot;
      return robot_seen && !client.servers().empty();
    });
  }
  std::vector<SessionStatus> statuses;
  for (auto& s : client.statuses()) {
    if (robot.empty() || s.robot_id == robot) statuses.push_back(std::move(s));
  }
  const auto servers = client.servers();
  if (statuses.empty() && servers.empty()) throw Failure(no_server_message(cl, timeout_s));
  if (statuses.empty() && !robot.empty()) {
    throw Failure("robot '" + robot + "' has no session on any of the " + std::to_string(servers.size()) +
                  " server(s) found; start one with: locctl use " + robot + " CONFIG.yaml");
  }
  if (cl.json) {
    Json sessions = Json::array();
    for (const auto& s : statuses) sessions.push_back(status_json(s));
    std::vector<std::string> server_ids;
    for (const auto& s : servers) server_ids.push_back(s.server_id);
    std::cout << Json{{"command", "status"}, {"ok", true}, {"servers", server_ids}, {"sessions", sessions}}.dump()
              << "\n";
    return 0;
  }
  if (statuses.empty()) {
    std::cout << "no sessions on " << servers.size() << " server(s)\n";
    return 0;
  }
  // New columns go before LAST_ERROR (free text, last), so scripts reading the older ones still work.
  const std::vector<std::string> header = {"ROBOT",   "STATE",   "PLUGIN",       "SERVER",   "RECEIVED",
                                           "USED",    "DROPPED", "REJECTED",     "UPDATES",  "LAST_MS",
                                           "LOCALIZATION", "FAILURES", "LOST",    "HELD",     "THROTTLED", "LAST_ERROR"};
  std::vector<std::vector<std::string>> rows = {header};
  for (const auto& s : statuses) {
    char last_ms[32];
    std::snprintf(last_ms, sizeof(last_ms), "%.3f", s.last_update_ms);
    rows.push_back({escaped(s.robot_id), s.state, s.plugin.empty() ? "-" : escaped(s.plugin), escaped(s.server_id),
                    std::to_string(s.received), std::to_string(s.used), std::to_string(s.dropped),
                    std::to_string(s.rejected), std::to_string(s.updates), last_ms, s.localization,
                    std::to_string(s.failures), std::to_string(s.lost), std::to_string(s.held),
                    std::to_string(s.throttled),
                    s.last_error.empty() ? "-" : escaped(s.last_error, 4096)});
  }
  std::vector<size_t> widths(header.size(), 0);
  for (const auto& row : rows) {
    for (size_t c = 0; c < row.size(); ++c) widths[c] = std::max(widths[c], row[c].size());
  }
  for (const auto& row : rows) {
    std::string line;
    for (size_t c = 0; c < row.size(); ++c) line += (c + 1 < row.size() ? pad(row[c], widths[c] + 2) : row[c]);
    std::cout << line << "\n";
  }
  return 0;
}

int command_plugins(const CommandLine& cl) {
  const double timeout_s = cl.timeout_s.value_or(2.0);
  Client client(client_options(cl, ""));
  // Every server publishes its ServerInfo transient-local; collect for the whole timeout so
  // servers discovered a little later are listed too.
  const auto deadline = Clock::now() + to_ms(timeout_s);
  client.wait_for_server(to_ms(timeout_s));
  std::this_thread::sleep_until(deadline);
  const auto servers = client.servers();
  if (servers.empty()) throw Failure(no_server_message(cl, timeout_s));
  if (cl.json) {
    Json items = Json::array();
    for (const auto& s : servers) {
      Json plugins = Json::array();
      for (const auto& p : s.plugins) {
        plugins.push_back({{"name", p.name}, {"version", p.version}, {"description", p.description}, {"consumes", p.consumes}});
      }
      items.push_back({{"server", s.server_id}, {"plugins", plugins}, {"rejected_plugins", s.rejected_plugins}});
    }
    std::cout << Json{{"command", "plugins"}, {"ok", true}, {"servers", items}}.dump() << "\n";
    return 0;
  }
  for (const auto& s : servers) {
    std::cout << "server " << s.server_id << ": " << s.plugins.size() << " plugin(s)\n";
    for (const auto& p : s.plugins) {
      std::string consumes;
      for (const auto& k : p.consumes) consumes += (consumes.empty() ? "" : ",") + k;
      std::cout << "  " << p.name << " " << p.version << "  consumes " << (consumes.empty() ? "-" : consumes) << "  "
                << p.description << "\n";
    }
    for (const auto& r : s.rejected_plugins) std::cout << "  rejected: " << r << "\n";
  }
  return 0;
}

double yaw_of(const Eigen::Isometry3d& pose) { return std::atan2(pose.linear()(1, 0), pose.linear()(0, 0)); }

std::string stamp_text(int64_t stamp_ns) {
  char text[48];
  const int64_t seconds = stamp_ns / 1'000'000'000;
  const int64_t micros = (stamp_ns % 1'000'000'000) / 1000;
  std::snprintf(text, sizeof(text), "%lld.%06lld", static_cast<long long>(seconds),
                static_cast<long long>(micros < 0 ? -micros : micros));
  return text;
}

int command_watch(const CommandLine& cl) {
  const std::string& robot = cl.arguments[0];
  std::mutex mutex;
  std::condition_variable arrived;
  std::deque<PoseUpdate> queue;
  Client client(client_options(cl, "", {robot}));
  client.on_pose(
      [&](const PoseUpdate& p) {
        std::lock_guard<std::mutex> lock(mutex);
        queue.push_back(p);
        arrived.notify_one();
      },
      robot);
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  long printed = 0;
  auto last_pose = Clock::now();
  while (!interrupted && (!cl.count || printed < *cl.count)) {
    std::unique_lock<std::mutex> lock(mutex);
    arrived.wait_for(lock, milliseconds(100), [&] { return !queue.empty(); });
    if (queue.empty()) {
      if (cl.timeout_s && Clock::now() - last_pose > to_ms(*cl.timeout_s)) {
        throw Failure("no pose for robot '" + robot + "' within " + seconds_text(*cl.timeout_s) +
                      (client.servers().empty() ? "; " + no_server_message(cl, *cl.timeout_s)
                                                : " (a server is up: is the robot's session running? locctl status " +
                                                      robot + ")"));
      }
      continue;
    }
    const PoseUpdate p = std::move(queue.front());
    queue.pop_front();
    lock.unlock();
    last_pose = Clock::now();
    const Eigen::Isometry3d& T = p.estimate.pose;
    const double yaw_deg = yaw_of(T) * 180.0 / M_PI;
    const double std_x = std::sqrt(std::max(0.0, p.estimate.covariance(0, 0)));
    const double std_y = std::sqrt(std::max(0.0, p.estimate.covariance(1, 1)));
    if (cl.json) {
      std::cout << Json{{"robot", p.robot_id}, {"stamp_ns", p.estimate.header.stamp_ns},
                        {"x", T.translation().x()}, {"y", T.translation().y()},
                        {"yaw_deg", yaw_deg}, {"std_x", std_x},
                        {"std_y", std_y}, {"plugin", p.plugin},
                        {"update_ms", p.update_ms}}
                       .dump()
                << std::endl;
    } else {
      char line[256];
      std::snprintf(line, sizeof(line), "%s x=%.3f y=%.3f yaw=%.2fdeg std_x=%.3f std_y=%.3f plugin=%s update=%.3fms",
                    stamp_text(p.estimate.header.stamp_ns).c_str(), T.translation().x(), T.translation().y(), yaw_deg,
                    std_x, std_y, escaped(p.plugin).c_str(), p.update_ms);
      std::cout << line << std::endl;
    }
    ++printed;
  }
  return 0;
}

// locctl security: the fleet's CA and identities (security.hpp), printing what was made.
int command_security(const CommandLine& cl) {
  namespace fs = std::filesystem;
  const std::string& verb = cl.arguments[0];
  const fs::path fleet = cl.arguments[1];
  security::Validity validity;
  try {
    // A few minutes in the past by default: a peer whose clock lags must not find it not yet valid.
    validity.start = cl.start ? security::parse_utc(*cl.start) : static_cast<long long>(std::time(nullptr)) - 300;
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--start: ") + e.what());
  }
  if (cl.days) validity.days = static_cast<int>(*cl.days);
  const auto run = security::system_runner();
  Json result = {{"command", "security " + verb}, {"ok", true}, {"fleet", fs::absolute(fleet).string()}};
  std::string text;
  if (verb == "init") {
    security::init(fleet, validity, run,
                   cl.rtps_protection ? security::parse_rtps_protection(*cl.rtps_protection) : security::RtpsProtection::kNone);
    text = "fleet CA in " + (fs::absolute(fleet) / "ca").string() + ", signed governance " +
           (fs::absolute(fleet) / "governance.p7s").string() + "; keep ca/ca.key secret";
  } else if (verb == "revoke") {
    security::Role role;
    try {
      role = security::parse_role(cl.arguments[2]);
    } catch (const std::invalid_argument& e) {
      throw UsageError(e.what());
    }
    const auto updated = security::revoke(fleet, role, cl.arguments[3], run);
    std::vector<std::string> folders;
    for (const auto& f : updated) folders.push_back(f.string());
    result["updated"] = folders;
    text = std::string(security::role_name(role)) + " '" + cl.arguments[3] + "' revoked; new CRL copied into " +
           std::to_string(folders.size()) + " identity folder(s); give it to the servers and restart them";
  } else {
    const security::Role role = security::parse_role(verb);
    const fs::path dir = security::make_identity(fleet, role, cl.arguments[2], validity, run);
    result["identity"] = dir.string();
    result["config"] = (dir / "cyclonedds.xml").string();
    text = verb + " '" + cl.arguments[2] + "' in " + dir.string() + "; use it with CYCLONEDDS_URI=<network config>,file://" +
           (dir / "cyclonedds.xml").string();
  }
  if (cl.json) {
    std::cout << result.dump() << "\n";
  } else {
    std::cout << text << "\n";
  }
  return 0;
}

int run(const CommandLine& cl) {
  if (cl.command == "use") return command_use(cl);
  if (cl.command == "status") return command_status(cl);
  if (cl.command == "watch") return command_watch(cl);
  if (cl.command == "plugins") return command_plugins(cl);
  if (cl.command == "stop") return command_stop(cl);
  if (cl.command == "initial-pose") return command_initial_pose(cl);
  if (cl.command == "record") return command_record(cl);
  if (cl.command == "security") return command_security(cl);
  throw UsageError("unknown command '" + cl.command + "'");
}

}  // namespace
}  // namespace locd::locctl

int main(int argc, char** argv) {
  using namespace locd::locctl;
  CommandLine cl;
  try {
    cl = parse_command_line(std::vector<std::string>(argv + 1, argv + argc), std::getenv("LOCD_DOMAIN"));
  } catch (const UsageError& e) {
    std::cerr << "locctl: " << e.what() << "\n";
    return kExitUsage;
  }
  if (cl.help) {
    std::cout << kUsage;
    return 0;
  }
  try {
    return run(cl);
  } catch (const std::exception& e) {
    if (cl.json) {
      std::cout << Json{{"command", cl.command}, {"ok", false}, {"error", e.what()}}.dump() << "\n";
    } else {
      std::cerr << "locctl " << cl.command << ": " << e.what() << "\n";
    }
    return kExitFailure;
  }
}
