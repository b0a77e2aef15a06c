#include "locd/server/server_config.hpp"

#include <unistd.h>

#include <cctype>
#include <fstream>
#include <sstream>

#include "locd/sdk/robot_id.hpp"
#include "locd/server/log.hpp"

namespace locd::server {
namespace fs = std::filesystem;
namespace {

std::vector<fs::path> directories(const Params& params, const std::string& key, const fs::path& base) {
  std::vector<fs::path> out;
  if (!params.has(key)) return out;
  const YAML::Node list = params.node()[key];
  if (!list.IsSequence()) params.fail(key, "is not a list; expected a list of directories, e.g. [../build/plugins]");
  for (size_t i = 0; i < list.size(); ++i) {
    if (!list[i].IsScalar() || list[i].Scalar().empty()) {
      params.fail(key, "entry " + std::to_string(i) + " is not a directory name; expected a list of directories");
    }
    const fs::path dir(list[i].Scalar());
    out.push_back((dir.is_absolute() ? dir : base / dir).lexically_normal());
  }
  return out;
}

size_t limit(const Params& limits, const char* key, size_t default_value, long max) {
  return static_cast<size_t>(limits.integer(key, static_cast<long>(default_value), 1, max));
}

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw ConfigError("cannot read config file '" + file.string() + "'");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

BootSession boot_session(const Params& entry, size_t index, const std::string& server_yaml,
                         const std::string& source_name, const fs::path& base) {
  entry.expect_only({"robot_id", "plugin", "config_file", "config", "initial_pose"});
  BootSession boot;
  boot.robot_id = entry.required_text("robot_id");
  if (const std::string error = robot_id_error(boot.robot_id); !error.empty()) {
    entry.fail("robot_id", "is not allowed: " + error);
  }
  const bool has_file = entry.has("config_file");
  const bool has_inline = entry.has("config");
  if (has_file == has_inline) {
    entry.fail(has_file ? "config" : "robot_id",
               "needs exactly one of 'config_file' (a file relative to the server config) or 'config' (an "
               "inline map with 'plugin' and 'params')");
  }
  if (has_file) {
    fs::path file(entry.required_text("config_file"));
    if (!file.is_absolute()) file = base / file;
    boot.source = file.lexically_normal().string();
    boot.text = {read_text(file), boot.source, {}};
    boot.config = split_plugin_config(boot.text);
  } else {
    boot.source = source_name + " (sessions entry for robot '" + boot.robot_id + "', " + entry.where("config") + ")";
    const YAML::Node inline_config = entry.node()["config"];
    if (!inline_config.IsMap()) entry.fail("config", "is not a map; expected 'plugin: <name>' and 'params:'");
    boot.config = split_plugin_config(Params(inline_config, entry.key_path("config")), boot.source);
    // The worker parses the server's config again and finds the entry by its keys, so its
    // messages name the same lines.
    boot.text = {server_yaml, source_name, {"sessions", std::to_string(index), "config"}};
  }
  const std::string plugin = entry.text("plugin", "");
  if (!plugin.empty()) {
    check_plugin_name(plugin, source_name + " (" + entry.where("plugin") + ")");
    if (plugin != boot.config.plugin) {
      entry.fail("plugin", "= '" + plugin + "' differs from the config's plugin '" + boot.config.plugin +
                               "'; leave it out or make them equal");
    }
  }
  if (entry.has("initial_pose")) {
    const auto pose = entry.numbers("initial_pose", {}, 3);
    boot.initial_pose = std::array<double, 3>{pose[0], pose[1], pose[2]};
  }
  return boot;
}

// Deadlines and sizes of the plugin_workers section (and of its per-plugin overrides).
constexpr double kMaxDeadlineS = 86400.0;
constexpr long kMaxSessionsPerWorker = 100000;

// request_limits: {session_requests: {per_s, burst}, initial_poses: {...}, map_saves: {...},
// session_requests_per_participant: {...}}.
void parse_rate(const Params& p, const std::string& key, RequestRate& r) {
  const Params rate = p.child(key);
  rate.expect_only({"per_s", "burst"});
  r.per_s = rate.number("per_s", r.per_s, Range::closed(0.001, 1e6));
  r.burst = static_cast<double>(rate.integer("burst", static_cast<long>(r.burst), 1, 1'000'000));
}

void parse_request_limits(const Params& p, RequestLimits& limits) {
  p.expect_only({"session_requests", "initial_poses", "map_saves", "session_requests_per_participant"});
  for (size_t k = 0; k < kRequestKinds; ++k) {
    const std::string key = std::string(request_limit_key(static_cast<RequestKind>(k))).substr(sizeof "request_limits");
    parse_rate(p, key, limits.rates[k]);
  }
  parse_rate(p, "session_requests_per_participant", limits.session_requests_per_participant);
}

// sessions_per_worker: 'auto' (WorkerSettings::kAuto) or 1..kMaxSessionsPerWorker.
size_t sessions_per_worker(const Params& p) {
  const YAML::Node value = p.node()["sessions_per_worker"];
  if (value.IsScalar() && value.Scalar() == "auto") return WorkerSettings::kAuto;
  if (value.IsScalar() && !value.Scalar().empty() && !std::isdigit(static_cast<unsigned char>(value.Scalar()[0]))) {
    p.fail("sessions_per_worker", "= '" + value.Scalar() + "' is neither 'auto' nor a count; allowed: auto or 1.." +
                                      std::to_string(kMaxSessionsPerWorker));
  }
  return static_cast<size_t>(p.integer("sessions_per_worker", 1, 1, kMaxSessionsPerWorker));
}

void parse_plugin_workers(const Params& p, const fs::path& base, ServerConfig& c) {
  p.expect_only({"executable", "sessions_per_worker", "workers_per_plugin", "configure_deadline_s", "update_deadline_s", "memory_limit_mb",
                 "liveness_timeout_s", "max_failures", "restart_backoff_s", "failure_reset_s", "plugins", "sandbox"});
  WorkerSettings& w = c.plugin_workers;
  if (p.has("executable")) {
    const fs::path exe(p.text("executable", ""));
    w.executable = (exe.is_absolute() ? exe : base / exe).lexically_normal();
  } else {
    w.executable = default_worker_executable();
  }
  if (p.has("sessions_per_worker")) w.sessions_per_worker = sessions_per_worker(p);
  w.workers_per_plugin = static_cast<size_t>(p.integer("workers_per_plugin", 0, 0, 10000));
  w.configure_deadline_s = p.number("configure_deadline_s", w.configure_deadline_s, Range::closed(0.01, kMaxDeadlineS));
  w.update_deadline_s = p.number("update_deadline_s", w.update_deadline_s, Range::closed(0.01, kMaxDeadlineS));
  w.memory_limit_mb = p.integer("memory_limit_mb", w.memory_limit_mb, 0, 1L << 30);
  if (w.memory_limit_mb > 0 && w.memory_limit_mb < 64) {
    p.fail("memory_limit_mb", "= " + std::to_string(w.memory_limit_mb) + " is too small to load a plugin; allowed: 0 (no limit) or 64..");
  }
  w.sandbox.enabled = p.flag("sandbox", true);
  w.liveness_timeout_s = p.number("liveness_timeout_s", w.liveness_timeout_s, Range::closed(0.0, kMaxDeadlineS));
  FailurePolicy& f = c.failures;
  f.max_failures = static_cast<uint32_t>(p.integer("max_failures", f.max_failures, 1, 1000));
  const auto backoff = p.numbers("restart_backoff_s", {f.backoff_initial_s, f.backoff_max_s}, 2, Range::closed(0.0, 3600.0));
  if (backoff[0] > backoff[1]) {
    p.fail("restart_backoff_s", "= [" + std::to_string(backoff[0]) + ", " + std::to_string(backoff[1]) +
                                    "]: the first delay exceeds the largest; expected [first, largest]");
  }
  f.backoff_initial_s = backoff[0];
  f.backoff_max_s = backoff[1];
  f.failure_reset_s = p.number("failure_reset_s", f.failure_reset_s, Range::closed(0.0, kMaxDeadlineS));
  const Params plugins = p.child("plugins");
  if (!plugins.node().IsMap()) p.fail("plugins", "is not a map; expected 'plugin_name: {update_deadline_s: ...}'");
  for (const auto& item : plugins.node()) {
    const std::string name = item.first.as<std::string>();
    check_plugin_name(name, "plugin_workers.plugins (" + plugins.where(name) + ")");
    const Params o = plugins.child(name);
    o.expect_only({"sessions_per_worker", "configure_deadline_s", "update_deadline_s"});
    WorkerSettings::Override override;
    if (o.has("sessions_per_worker")) {
      override.sessions_per_worker = sessions_per_worker(o);
    }
    if (o.has("configure_deadline_s")) {
      override.configure_deadline_s = o.number("configure_deadline_s", 0.0, Range::closed(0.01, kMaxDeadlineS));
    }
    if (o.has("update_deadline_s")) {
      override.update_deadline_s = o.number("update_deadline_s", 0.0, Range::closed(0.01, kMaxDeadlineS));
    }
    w.plugins[name] = override;
  }
}

}  // namespace

fs::path default_worker_executable() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path("locd-worker") : self.parent_path() / "locd-worker";
}

WorkerSettings worker_settings(const ServerConfig& config) {
  WorkerSettings settings = config.plugin_workers;
  settings.sandbox.readable = config.plugin_directories;
  settings.sandbox.readable.insert(settings.sandbox.readable.end(), config.map_directories.begin(),
                                   config.map_directories.end());
  settings.sandbox.writable = config.output_directory;
  return settings;
}

InspectorSettings inspector_settings(const ServerConfig& config) {
  InspectorSettings settings;
  settings.executable = config.plugin_workers.executable;
  settings.sandbox = worker_settings(config).sandbox;
  settings.timeout_s = config.plugin_workers.configure_deadline_s;
  settings.memory_limit_mb = config.plugin_workers.memory_limit_mb;
  return settings;
}

std::string default_server_id() {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) != 0) std::snprintf(host, sizeof host, "locd");
  return std::string(host) + "-" + std::to_string(getpid());
}

ServerConfig ServerConfig::parse(const std::string& yaml_text, const std::string& source_name,
                                 const fs::path& base_directory) {
  const Params root = Params::parse(yaml_text, source_name);
  root.expect_only({"server_id", "domain_id", "plugin_directories", "map_directories", "output_directory", "workers",
                    "queue_depth", "max_sessions", "status_period_s", "session_grace_s", "limits", "log_level",
                    "sessions", "plugin_workers", "state_directory", "weight", "server_group",
                    "request_limits"});
  ServerConfig c;
  c.server_id = root.text("server_id", default_server_id());
  if (c.server_id.empty() || c.server_id.size() > 64) {
    root.fail("server_id", "= '" + c.server_id + "' must have 1 to 64 characters");
  }
  c.domain_id = static_cast<int>(root.integer("domain_id", 0, 0, 232));
  c.plugin_directories = directories(root, "plugin_directories", base_directory);
  c.map_directories = directories(root, "map_directories", base_directory);
  if (root.has("output_directory")) {
    const fs::path dir = base_directory / root.text("output_directory", "");
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) root.fail("output_directory", "= '" + dir.string() + "' is not an existing directory");
    c.output_directory = fs::canonical(dir, ec);
  }
  c.workers = static_cast<int>(root.integer("workers", 2, 1, 64));
  c.queue_depth = static_cast<int>(root.integer("queue_depth", 64, 1, 10000));
  c.max_sessions = static_cast<size_t>(root.integer("max_sessions", 256, 1, 100000));
  c.status_period_s = root.number("status_period_s", 1.0, Range::closed(0.05, 3600.0));
  c.session_grace_s = root.number("session_grace_s", c.session_grace_s, Range::closed(0.1, 86400.0));
  c.log_level = parse_log_level(root.text("log_level", "info", {"debug", "info", "warning", "error"}));

  if (root.has("state_directory")) {
    const fs::path dir = base_directory / root.text("state_directory", "");
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) root.fail("state_directory", "= '" + dir.string() + "' is not an existing directory");
    c.state_directory = fs::canonical(dir, ec);
  }
  parse_plugin_workers(root.child("plugin_workers"), base_directory, c);
  c.weight = root.number("weight", 1.0, Range::closed(0.001, 1000.0));
  c.server_group = root.text("server_group", "");
  if (c.server_group.size() > 64) root.fail("server_group", "is longer than 64 characters");

  const Params limits = root.child("limits");
  limits.expect_only({"max_scan_beams", "max_cloud_points", "max_image_pixels", "max_detections",
                      "max_particles", "max_map_cells"});
  // Upper ends: the IDL's sequence bounds for sensors, generous sanity bounds for the rest.
  const Limits defaults;
  c.limits.max_scan_beams = limit(limits, "max_scan_beams", defaults.max_scan_beams, 65536);
  c.limits.max_cloud_points = limit(limits, "max_cloud_points", defaults.max_cloud_points, 4194304);
  c.limits.max_image_pixels = limit(limits, "max_image_pixels", defaults.max_image_pixels, 33554432);
  c.limits.max_detections = limit(limits, "max_detections", defaults.max_detections, 4096);
  c.limits.max_particles = limit(limits, "max_particles", defaults.max_particles, 10'000'000);
  c.limits.max_map_cells = limit(limits, "max_map_cells", defaults.max_map_cells, 1'000'000'000);

  parse_request_limits(root.child("request_limits"), c.request_limits);

  if (root.has("sessions")) {
    const YAML::Node list = root.node()["sessions"];
    if (!list.IsSequence()) root.fail("sessions", "is not a list; expected a list of {robot_id, config_file | config}");
    for (size_t i = 0; i < list.size(); ++i) {
      if (!list[i].IsMap()) {
        root.fail("sessions", "entry " + std::to_string(i) + " is not a map; expected {robot_id, config_file | config}");
      }
      BootSession boot = boot_session(Params(list[i], "sessions[" + std::to_string(i) + "]"), i, yaml_text,
                                      source_name, base_directory);
      for (const auto& other : c.sessions) {
        if (other.robot_id == boot.robot_id) {
          root.fail("sessions", "names robot '" + boot.robot_id + "' twice; one session per robot");
        }
      }
      c.sessions.push_back(std::move(boot));
    }
  }
  return c;
}

ServerConfig ServerConfig::load_file(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw ConfigError("cannot read server config file '" + file.string() + "'");
  std::stringstream text;
  text << in.rdbuf();
  const fs::path absolute = fs::absolute(file);
  return parse(text.str(), file.string(), absolute.parent_path());
}

}  // namespace locd::server
