#include "command_line.hpp"

#include <CLI/CLI.hpp>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>

#include "locd/sdk/robot_id.hpp"

namespace locd::locctl {

const char* const kUsage = R"(usage: locctl [options] COMMAND [ARGS]

Commands:
  use ROBOT CONFIG.yaml        start or switch ROBOT's localizer with a plugin config
                               (plugin: NAME, params: {...}); prints the server's answer
  status [ROBOT]               sessions with state, plugin, counters and last error
  watch ROBOT [--count N]      one line per pose received; stops after N poses or on Ctrl-C
  plugins                      what each discovered server can load, and rejected plugin files
  stop ROBOT                   end ROBOT's session
  initial-pose ROBOT X Y YAW   give ROBOT's localizer its pose (metres, YAW in radians)
                               [--std-xy M (default 0.5)] [--std-yaw RAD (default 0.2)]
  record OUT.mcap [ROBOT...]   record every locd topic of those robots (default: every robot),
                               sensors included, into MCAP until Ctrl-C or --duration S
                               [--compression zstd|lz4|none (default zstd)]
  security init FLEET          make the fleet's CA and signed governance in folder FLEET
                               [--rtps-protection none|sign|encrypt (default none): whole RTPS
                               messages too, beyond every topic's encrypted data]
  security robot FLEET ROBOT   make an identity in FLEET/<role>/<name>: key, certificate, signed
  security operator FLEET NAME   permissions and cyclonedds.xml (DDS Security config). A robot
  security monitor FLEET NAME    feeds and steers only itself, an operator steers any robot, a
  security server FLEET NAME     monitor only reads, a server serves
                               [--days N (default 365)] [--start 2026-11-25T10:00:00Z (default 5 min ago)]
  security revoke FLEET ROLE NAME  revoke an identity; copies the new CRL into FLEET's identities

Options:
  --domain N     DDS domain id 0..232 (default: env LOCD_DOMAIN, else 0)
  --timeout S    seconds to wait for servers and answers (default: 2 for status and plugins,
                 10 for use and stop, 5 for initial-pose; watch: fail when no pose arrives
                 for S seconds, default wait forever)
  --json         print JSON: one object, or one object per line for watch
  --help, -h     this text

DDS settings come from CYCLONEDDS_URI, which must match the server's (e.g.
CYCLONEDDS_URI=file://$PWD/config/dds/loopback.xml for the local demo).
Exit status: 0 success, 1 failure (no server, request refused, timeout), 2 usage error.
)";

namespace {

// Number of positional arguments each command takes: {min, max}.
const std::map<std::string, std::pair<size_t, size_t>>& command_arity() {
  static const std::map<std::string, std::pair<size_t, size_t>> arity = {
      {"use", {2, 2}},   {"status", {0, 1}}, {"watch", {1, 1}},        {"plugins", {0, 0}},
      {"stop", {1, 1}},  {"help", {0, 0}},   {"initial-pose", {4, 4}}, {"record", {1, 1001}},
      {"security", {2, 4}},
  };
  return arity;
}

const char* arguments_of(const std::string& command) {
  if (command == "use") return "ROBOT CONFIG.yaml";
  if (command == "status") return "[ROBOT]";
  if (command == "watch") return "ROBOT";
  if (command == "stop") return "ROBOT";
  if (command == "initial-pose") return "ROBOT X Y YAW";
  if (command == "record") return "OUT.mcap [ROBOT...] (at most 1000 robots)";
  if (command == "security") return "init FLEET | robot|operator|monitor|server FLEET NAME | revoke FLEET ROLE NAME";
  return "no arguments";
}

double parse_number(const std::string& option, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(value)) {
    throw UsageError(option + " = '" + text + "' is not a finite number");
  }
  return value;
}

long parse_integer(const std::string& option, const std::string& text, long min, long max) {
  errno = 0;
  char* end = nullptr;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE || value < min || value > max) {
    throw UsageError(option + " = '" + text + "' is not an integer in [" + std::to_string(min) + ", " +
                     std::to_string(max) + "]");
  }
  return value;
}

}  // namespace

namespace {

// Option values as typed, before conversion (each message names the option and the value).
struct RawOptions {
  std::string domain, timeout, count, std_xy, std_yaw, duration, compression, days, start, rtps_protection;
};

// The options' values converted and checked against their ranges.
void convert_options(const RawOptions& o, CommandLine& cl) {
  if (!o.domain.empty()) cl.domain = static_cast<unsigned>(parse_integer("--domain", o.domain, 0, 232));
  if (!o.timeout.empty()) {
    const double t = parse_number("--timeout", o.timeout);
    if (!(t > 0.0 && t <= 86400.0)) throw UsageError("--timeout = " + o.timeout + " is out of range; allowed: (0, 86400] seconds");
    cl.timeout_s = t;
  }
  if (!o.count.empty()) cl.count = parse_integer("--count", o.count, 1, 1'000'000'000);
  if (!o.std_xy.empty()) {
    cl.std_xy = parse_number("--std-xy", o.std_xy);
    if (!(cl.std_xy > 0.0)) throw UsageError("--std-xy = " + o.std_xy + " must be > 0 (metres)");
  }
  if (!o.std_yaw.empty()) {
    cl.std_yaw = parse_number("--std-yaw", o.std_yaw);
    if (!(cl.std_yaw > 0.0)) throw UsageError("--std-yaw = " + o.std_yaw + " must be > 0 (radians)");
  }
  if (!o.duration.empty()) {
    const double d = parse_number("--duration", o.duration);
    if (!(d > 0.0 && d <= 31.0 * 86400.0)) throw UsageError("--duration = " + o.duration + " is out of range; allowed: (0, 2678400] seconds");
    cl.duration_s = d;
  }
  if (!o.compression.empty()) {
    if (o.compression != "zstd" && o.compression != "lz4" && o.compression != "none") {
      throw UsageError("--compression = '" + o.compression + "'; allowed: zstd, lz4, none");
    }
    cl.compression = o.compression;
  }
  if (!o.days.empty()) cl.days = parse_integer("--days", o.days, 1, 36500);
  if (!o.start.empty()) cl.start = o.start;
  if (!o.rtps_protection.empty()) {
    if (o.rtps_protection != "none" && o.rtps_protection != "sign" && o.rtps_protection != "encrypt") {
      throw UsageError("--rtps-protection = '" + o.rtps_protection + "'; allowed: none, sign, encrypt");
    }
    cl.rtps_protection = o.rtps_protection;
  }
}

// The command's arguments and the options it allows.
void check_command(const RawOptions& o, CommandLine& cl) {
  const auto arity = command_arity().find(cl.command);
  if (arity == command_arity().end()) {
    throw UsageError("unknown command '" + cl.command +
                     "'; commands: use, status, watch, plugins, stop, initial-pose, record, security (see locctl --help)");
  }
  if (cl.help) return;
  const auto [min_args, max_args] = arity->second;
  if (cl.arguments.size() < min_args || cl.arguments.size() > max_args) {
    throw UsageError("'" + cl.command + "' takes " + arguments_of(cl.command) + ", got " +
                     std::to_string(cl.arguments.size()) + " argument(s); see locctl --help");
  }
  if (cl.count && cl.command != "watch") throw UsageError("--count applies to 'watch' only");
  if ((!o.duration.empty() || !o.compression.empty()) && cl.command != "record") {
    throw UsageError("--duration and --compression apply to 'record' only");
  }
  if ((cl.days || cl.start) && cl.command != "security") throw UsageError("--days and --start apply to 'security' only");
  if (cl.rtps_protection && cl.command != "security") throw UsageError("--rtps-protection applies to 'security init' only");
  if (cl.command == "security") {
    const std::string& verb = cl.arguments[0];
    const size_t expected = verb == "init" ? 2 : verb == "revoke" ? 4 : 3;
    if (verb != "init" && verb != "revoke" && verb != "robot" && verb != "operator" && verb != "monitor" &&
        verb != "server") {
      throw UsageError("'security " + verb + "' is not a security command; allowed: init, robot, operator, monitor, "
                       "server, revoke (see locctl --help)");
    }
    if (cl.rtps_protection && verb != "init") throw UsageError("--rtps-protection applies to 'security init' only");
    if (cl.arguments.size() != expected) {
      throw UsageError("'security " + verb + "' takes " + std::to_string(expected - 1) + " argument(s), got " +
                       std::to_string(cl.arguments.size() - 1) + "; see locctl --help");
    }
    return;
  }
  if (cl.command == "initial-pose") {
    parse_number("X", cl.arguments[1]);
    parse_number("Y", cl.arguments[2]);
    parse_number("YAW", cl.arguments[3]);
  }
  if (!cl.arguments.empty() && cl.command != "plugins" && cl.command != "record") {
    // The robot id names the robot's DDS partition: the same rule as the server's (robot_id.hpp).
    if (const std::string error = robot_id_error(cl.arguments[0]); !error.empty()) throw UsageError("ROBOT: " + error);
  }
}

}  // namespace

CommandLine parse_command_line(const std::vector<std::string>& args, const char* domain_env) {
  CommandLine cl;
  if (domain_env && *domain_env) cl.domain = static_cast<unsigned>(parse_integer("LOCD_DOMAIN", domain_env, 0, 232));
  // CLI11 finds the options anywhere on the line; the values are read as text and converted
  // below, so every message names the option, the value and what is allowed.
  CLI::App app{"locctl", "locctl"};
  app.set_help_flag();
  app.allow_extras();
  std::vector<std::string> words;
  RawOptions o;
  app.add_option("words", words);
  app.add_flag("--help,-h", cl.help);
  app.add_flag("--json", cl.json);
  app.add_option("--domain", o.domain);
  app.add_option("--timeout", o.timeout);
  app.add_option("--count", o.count);
  app.add_option("--std-xy", o.std_xy);
  app.add_option("--std-yaw", o.std_yaw);
  app.add_option("--duration", o.duration);
  app.add_option("--compression", o.compression);
  app.add_option("--days", o.days);
  app.add_option("--start", o.start);
  app.add_option("--rtps-protection", o.rtps_protection);
  for (size_t i = 0; i < args.size(); ++i) {
    const bool takes_value = args[i] == "--domain" || args[i] == "--timeout" || args[i] == "--count" ||
                             args[i] == "--std-xy" || args[i] == "--std-yaw" || args[i] == "--duration" ||
                             args[i] == "--compression" || args[i] == "--days" || args[i] == "--start" ||
                             args[i] == "--rtps-protection";
    if (takes_value && i + 1 == args.size()) throw UsageError("option " + args[i] + " needs a value");
  }
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them last first
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    throw UsageError(std::string(e.what()) + "; see locctl --help");
  }
  for (const std::string& extra : app.remaining()) {
    if (extra.size() > 1 && extra[0] == '-') throw UsageError("unknown option '" + extra + "'; see locctl --help");
    words.push_back(extra);
  }
  convert_options(o, cl);
  if (words.empty()) {
    if (cl.help) {
      cl.command = "help";
      return cl;
    }
    throw UsageError("no command given; commands: use, status, watch, plugins, stop, initial-pose, record, security (see locctl --help)");
  }
  cl.command = words.front();
  cl.arguments.assign(words.begin() + 1, words.end());
  check_command(o, cl);
  if (cl.command == "help") cl.help = true;
  return cl;
}

}  // namespace locd::locctl
