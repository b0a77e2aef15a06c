// locd: the localization daemon. See `locd --help` and config/locd.yaml.
#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "locd/dds/dds.hpp"
#include "locd/server/dds_bridge.hpp"
#include "locd/server/dds_log.hpp"
#include "locd/server/log.hpp"
#include "locd/server/plugin_index.hpp"
#include "locd/server/plugin_workers.hpp"
#include "locd/server/ros2_bridge.hpp"
#include "locd/server/server.hpp"
#include "locd/server/server_config.hpp"

namespace {

using namespace locd;
using namespace locd::server;
namespace fs = std::filesystem;

constexpr const char* kUsage = R"(locd: localization server for networked robots (DDS)

Usage:
  locd --config FILE [options]        run the server
  locd --check-config FILE [options]  validate FILE, its plugin directories and boot sessions; print OK
                                      or the error; exit 0 or 1
  locd --help                         this text

Options:
  --domain N          DDS domain id, overrides the config's domain_id (0..232)
  --plugin-dir DIR    one more plugin directory (repeatable)
  --log-level LEVEL   debug | info | warning | error (overrides the config)

DDS settings come from CYCLONEDDS_URI (e.g. file://config/dds/loopback.xml for loopback only).
SIGINT or SIGTERM shut the server down cleanly.
)";

struct Options {
  std::string config_file;
  bool check_only = false;
  std::optional<long> domain;
  std::vector<std::string> plugin_dirs;
  std::optional<std::string> log_level;
};

// Robots without a session the bridge keeps status writers for (their "no session" answers),
// beyond max_sessions; the least recently answered go first.
constexpr size_t kUnservedRobotsWithWriters = 256;

// At shutdown, how long plugin workers get to exit before they are killed (a hung plugin never
// exits): SIGTERM completes well within 2 s.
constexpr std::chrono::milliseconds kWorkerExitGrace{500};
// How often the server applies the fleet's rules (fleet.hpp).
constexpr std::chrono::milliseconds kFleetTick{50};

int signal_pipe[2] = {-1, -1};

extern "C" void on_signal(int) {
  const int saved = errno;
  const char byte = 1;
  [[maybe_unused]] const ssize_t n = write(signal_pipe[1], &byte, 1);
  errno = saved;
}

Options parse_arguments(int argc, char** argv) {
  Options o;
  auto value = [&](int& i, const std::string& flag) -> std::string {
    if (i + 1 >= argc) throw ConfigError("option " + flag + " needs a value (see locd --help)");
    return argv[++i];
  };
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else if (arg == "--config") {
      o.config_file = value(i, arg);
    } else if (arg == "--check-config") {
      o.config_file = value(i, arg);
      o.check_only = true;
    } else if (arg == "--domain") {
      const std::string text = value(i, arg);
      char* end = nullptr;
      const long domain = std::strtol(text.c_str(), &end, 10);
      if (text.empty() || *end != '\0' || domain < 0 || domain > 232) {
        throw ConfigError("--domain '" + text + "' is not allowed; expected an integer in [0, 232]");
      }
      o.domain = domain;
    } else if (arg == "--plugin-dir") {
      o.plugin_dirs.push_back(value(i, arg));
    } else if (arg == "--log-level") {
      const std::string level = value(i, arg);
      parse_log_level(level);
      o.log_level = level;
    } else {
      throw ConfigError("unknown option '" + arg + "' (see locd --help)");
    }
  }
  if (o.config_file.empty()) throw ConfigError("no config given: use --config FILE or --check-config FILE (see locd --help)");
  return o;
}

ServerConfig load_config(const Options& o) {
  ServerConfig config = ServerConfig::load_file(o.config_file);
  if (o.domain) config.domain_id = static_cast<int>(*o.domain);
  for (const auto& dir : o.plugin_dirs) config.plugin_directories.push_back(fs::absolute(dir).lexically_normal());
  if (o.log_level) config.log_level = parse_log_level(*o.log_level);
  std::error_code ec;
  for (const auto& dir : config.plugin_directories) {
    if (!fs::is_directory(dir, ec)) throw ConfigError("plugin directory '" + dir.string() + "' does not exist");
  }
  for (const auto& dir : config.map_directories) {
    if (!fs::is_directory(dir, ec)) throw ConfigError("map directory '" + dir.string() + "' does not exist");
  }
  return config;
}

// Hears the answer to one configure request (check_boot_sessions).
class ConfigureCheck : public InstanceOwner {
 public:
  void on_reply(uint64_t, worker::Reply reply) override {
    finish(reply.outcome == worker::Outcome::kOk ? "" : reply.message.empty() ? "configure failed" : reply.message);
  }
  void on_log(uint64_t, const worker::LogLine&) override {}
  void on_lost(uint64_t, const WorkerLoss& loss) override { finish(loss.description); }
  // The error ("" when the plugin took the config).
  std::string wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return answered_; });
    return error_;
  }

 private:
  void finish(const std::string& error) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (answered_) return;
    answered_ = true;
    error_ = error;
    done_.notify_all();
  }
  std::mutex mutex_;
  std::condition_variable done_;
  bool answered_ = false;
  std::string error_;
};

// Configures every boot session's plugin once in a worker, as the server would, and releases it:
// plugin code never runs in locd, not even to check a config.
void check_boot_sessions(const ServerConfig& config, const PluginIndex& catalog, Logger& logger) {
  if (config.sessions.empty()) return;
  PluginWorkers workers(worker_settings(config), config.limits, logger);
  for (const auto& boot : config.sessions) {
    std::string error;
    try {
      auto check = std::make_shared<ConfigureCheck>();
      const uint64_t instance = workers.create_instance(catalog.require(boot.config.plugin), check);
      worker::ConfigureRequest request;
      request.robot_id = boot.robot_id;
      request.limits = config.limits;
      for (const auto& dir : config.map_directories) request.map_directories.push_back(dir.string());
      request.output_directory = config.output_directory.string();
      request.config = boot.text;
      if (!workers.configure(instance, request, "configure of the boot session")) {
        error = "its worker ended before it could be configured";
      } else {
        error = check->wait();
      }
      workers.release(instance);
    } catch (const std::exception& e) {
      error = e.what();
    }
    if (!error.empty()) {
      workers.shutdown(kWorkerExitGrace);
      throw ConfigError("boot session for robot '" + boot.robot_id + "' (" + boot.source + "): " + error);
    }
  }
  workers.shutdown(kWorkerExitGrace);
}

int check_config(const Options& o) {
  try {
    const ServerConfig config = load_config(o);
    std::error_code ec;
    if (!fs::is_regular_file(config.plugin_workers.executable, ec)) {
      throw ConfigError("plugin worker '" + config.plugin_workers.executable.string() +
                        "' not found; install locd-worker next to locd or set plugin_workers.executable");
    }
    Logger logger(LogLevel::kWarning);  // what the inspectors and workers write to stderr
    const PluginIndex catalog(config.plugin_directories, inspector_settings(config), logger);
    check_boot_sessions(config, catalog, logger);
    std::string plugins;
    for (const auto& name : catalog.names()) plugins += (plugins.empty() ? "" : ", ") + name;
    for (const auto& rejected : catalog.rejected()) std::cout << "warning: plugin refused: " << rejected << "\n";
    std::cout << "OK: " << o.config_file << " (server " << config.server_id << ", domain " << config.domain_id
              << ", plugins: " << (plugins.empty() ? "none" : plugins) << ", boot sessions: " << config.sessions.size()
              << ")\n";
    return 0;
  } catch (const std::exception& e) {
    std::cout << "error: " << o.config_file << ": " << e.what() << "\n";
    return 1;
  }
}

int run(const Options& o) {
  Logger logger;
  ServerConfig config;
  try {
    config = load_config(o);
  } catch (const std::exception& e) {
    logger.log(LogLevel::kError, "server", o.config_file + ": " + e.what());
    return 1;
  }
  logger.set_level(config.log_level);
  const std::string uri = dds::config_uri();
  if (uri.empty()) {
    logger.log(LogLevel::kWarning, "server",
               "CYCLONEDDS_URI is unset: Cyclone DDS uses the machine's real network interface");
  } else {
    logger.log(LogLevel::kInfo, "server", "CYCLONEDDS_URI=" + uri);
  }

  if (pipe(signal_pipe) != 0) {
    logger.log(LogLevel::kError, "server", std::string("pipe: ") + std::strerror(errno));
    return 1;
  }
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);

  std::error_code ec;
  if (!fs::is_regular_file(config.plugin_workers.executable, ec)) {
    logger.log(LogLevel::kError, "server",
               "plugin worker '" + config.plugin_workers.executable.string() +
                   "' not found: plugins run in locd-worker processes; install it next to locd or set "
                   "plugin_workers.executable");
    return 1;
  }
  // Each plugin file is inspected by a sandboxed locd-worker: no plugin code is mapped into locd.
  const PluginIndex catalog(config.plugin_directories, inspector_settings(config), logger);
  for (const auto& name : catalog.names()) {
    logger.log(LogLevel::kInfo, "server", "plugin " + name + " " + catalog.find(name)->version + " from " +
                                              catalog.find(name)->file.string());
  }
  for (const auto& rejected : catalog.rejected()) logger.log(LogLevel::kWarning, "server", "plugin refused: " + rejected);

  const DdsLogForwarder dds_log(logger);  // Cyclone's own errors (refused peers, certificates) into this log
  try {
    DdsBridge bridge(config.domain_id, config.server_id, config.limits, logger, config.max_sessions + kUnservedRobotsWithWriters);
    Ros2Bridge ros2(bridge.participant(), config.limits, bridge, logger);  // ROS 2 robots' topics, then `bridge`
    Server server(config, catalog, ros2, logger);
    server.set_session_observer(&ros2);
    // Whatever way this scope ends, the listeners stop before the server they call goes away.
    struct ReadersFirst {
      DdsBridge& bridge;
      Ros2Bridge& ros2;
      ~ReadersFirst() { bridge.disconnect(); ros2.disconnect(); }
    } readers_first{bridge, ros2};
    ros2.connect(server);
    server.boot();
    bridge.connect(server);
    logger.log(LogLevel::kInfo, "server",
               "locd " + config.server_id + " running on domain " + std::to_string(config.domain_id) + " with " +
                   std::to_string(config.workers) + " workers, " + std::to_string(catalog.names().size()) + " plugins");

    // The loop wakes every kFleetTick to apply the fleet's rules (a dead server's robots are
    // taken over within its lease plus this), and publishes statuses once per status period.
    const auto status_period = std::chrono::duration<double>(config.status_period_s);
    auto next_status = std::chrono::steady_clock::now() + status_period;
    for (;;) {
      pollfd fd{signal_pipe[0], POLLIN, 0};
      const int ready = poll(&fd, 1, static_cast<int>(kFleetTick.count()));
      if (ready > 0) break;
      if (ready < 0 && errno != EINTR) {
        logger.log(LogLevel::kError, "server", std::string("poll: ") + std::strerror(errno));
        break;
      }
      server.rebalance();
      if (std::chrono::steady_clock::now() >= next_status) {
        next_status += std::chrono::duration_cast<std::chrono::steady_clock::duration>(status_period);
        server.publish_all_status();
        server.save_state();
        server.end_ownerless_sessions();
      }
    }
    logger.log(LogLevel::kInfo, "server", "shutting down: stopping readers, then workers");
    bridge.disconnect();
    ros2.disconnect();
    server.save_state();
    server.shutdown(kWorkerExitGrace);
  } catch (const std::exception& e) {
    logger.log(LogLevel::kError, "server", e.what());
    return 1;
  }
  logger.log(LogLevel::kInfo, "server", "stopped");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  try {
    options = parse_arguments(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "locd: " << e.what() << "\n";
    return 2;
  }
  return options.check_only ? check_config(options) : run(options);
}
