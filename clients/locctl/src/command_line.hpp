// locctl's command line: the command, its positional arguments and the options, validated.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace locd::locctl {

// Wrong usage: locctl prints the message and exits with status 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CommandLine {
  std::string command;                 // use, status, watch, plugins, stop, initial-pose, record, security, help
  std::vector<std::string> arguments;  // positional arguments after the command
  unsigned domain = 0;                 // --domain, else env LOCD_DOMAIN, else 0
  std::optional<double> timeout_s;     // --timeout
  bool json = false;                   // --json
  bool help = false;                   // --help / -h / help
  std::optional<long> count;           // --count (watch)
  double std_xy = 0.5;                 // --std-xy (initial-pose), m
  double std_yaw = 0.2;                // --std-yaw (initial-pose), rad
  std::optional<double> duration_s;    // --duration (record): stop after S seconds
  std::string compression = "zstd";    // --compression (record): zstd, lz4, none
  std::optional<long> days;            // --days (security): validity of what is made
  std::optional<std::string> start;    // --start (security): when it becomes valid, UTC
  std::optional<std::string> rtps_protection;  // --rtps-protection (security init): none, sign, encrypt
};

// Parses argv (options may come before or after the command). `domain_env` is the value of
// LOCD_DOMAIN (nullptr when unset). Throws UsageError naming the option, the value and what is
// allowed.
CommandLine parse_command_line(const std::vector<std::string>& args, const char* domain_env);

extern const char* const kUsage;

}  // namespace locd::locctl
