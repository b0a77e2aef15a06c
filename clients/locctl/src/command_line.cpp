#include "command_line.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>

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

constexpr size_t kMaxRobotIdLength = 64;  // locd.idl ROBOT_ID_MAX

// Number of positional arguments each command takes: {min, max}.
const std::map<std::string, std::pair<size_t, size_t>>& command_arity() {
  static const std::map<std::string, std::pair<size_t, size_t>> arity = {
      {"use", {2, 2}},   {"status", {0, 1}}, {"watch", {1, 1}},        {"plugins", {0, 0}},
      {"stop", {1, 1}},  {"help", {0, 0}},   {"initial-pose", {4, 4}},
  };
  return arity;
}

const char* arguments_of(const std::string& command) {
  if (command == "use") return "ROBOT CONFIG.yaml";
  if (command == "status") return "[ROBOT]";
  if (command == "watch") return "ROBOT";
  if (command == "stop") return "ROBOT";
  if (command == "initial-pose") return "ROBOT X Y YAW";
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

CommandLine parse_command_line(const std::vector<std::string>& args, const char* domain_env) {
  CommandLine cl;
  if (domain_env && *domain_env) cl.domain = static_cast<unsigned>(parse_integer("LOCD_DOMAIN", domain_env, 0, 232));
  std::vector<std::string> words;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&]() -> const std::string& {
      if (i + 1 >= args.size()) throw UsageError("option " + a + " needs a value");
      return args[++i];
    };
    if (a == "--help" || a == "-h") {
      cl.help = true;
    } else if (a == "--json") {
      cl.json = true;
    } else if (a == "--domain") {
      cl.domain = static_cast<unsigned>(parse_integer("--domain", value(), 0, 232));
    } else if (a == "--timeout") {
      const double t = parse_number("--timeout", value());
      if (!(t > 0.0 && t <= 86400.0)) throw UsageError("--timeout = " + args[i] + " is out of range; allowed: (0, 86400] seconds");
      cl.timeout_s = t;
    } else if (a == "--count") {
      cl.count = parse_integer("--count", value(), 1, 1'000'000'000);
    } else if (a == "--std-xy") {
      cl.std_xy = parse_number("--std-xy", value());
      if (!(cl.std_xy > 0.0)) throw UsageError("--std-xy = " + args[i] + " must be > 0 (metres)");
    } else if (a == "--std-yaw") {
      cl.std_yaw = parse_number("--std-yaw", value());
      if (!(cl.std_yaw > 0.0)) throw UsageError("--std-yaw = " + args[i] + " must be > 0 (radians)");
    } else if (a.size() > 1 && a[0] == '-' && !(a.size() > 1 && (std::isdigit(static_cast<unsigned char>(a[1])) || a[1] == '.'))) {
      throw UsageError("unknown option '" + a + "'; see locctl --help");
    } else {
      words.push_back(a);
    }
  }
  if (words.empty()) {
    if (cl.help) {
      cl.command = "help";
      return cl;
    }
    throw UsageError("no command given; commands: use, status, watch, plugins, stop, initial-pose (see locctl --help)");
  }
  cl.command = words.front();
  cl.arguments.assign(words.begin() + 1, words.end());
  const auto arity = command_arity().find(cl.command);
  if (arity == command_arity().end()) {
    throw UsageError("unknown command '" + cl.command +
                     "'; commands: use, status, watch, plugins, stop, initial-pose (see locctl --help)");
  }
  if (cl.help) return cl;
  const auto [min_args, max_args] = arity->second;
  if (cl.arguments.size() < min_args || cl.arguments.size() > max_args) {
    throw UsageError("'" + cl.command + "' takes " + arguments_of(cl.command) + ", got " +
                     std::to_string(cl.arguments.size()) + " argument(s); see locctl --help");
  }
  if (cl.count && cl.command != "watch") throw UsageError("--count applies to 'watch' only");
  if (cl.command == "initial-pose") {
    parse_number("X", cl.arguments[1]);
    parse_number("Y", cl.arguments[2]);
    parse_number("YAW", cl.arguments[3]);
  }
  if (!cl.arguments.empty() && cl.command != "plugins") {
    const std::string& robot = cl.arguments[0];
    if (robot.empty()) throw UsageError("ROBOT must not be empty");
    if (robot.size() > kMaxRobotIdLength) {
      throw UsageError("ROBOT '" + robot.substr(0, 32) + "...' is longer than " + std::to_string(kMaxRobotIdLength) +
                       " characters");
    }
  }
  if (cl.command == "help") cl.help = true;
  return cl;
}

}  // namespace locd::locctl
