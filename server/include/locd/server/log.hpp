// One line per event on stderr:
//   2026-11-21T23:40:01.123Z info [robot1] session started: plugin feature_ekf
// Thread-safe; lines below the configured level are skipped. Subject and message are escaped
// (locd/sdk/text.hpp): a newline in a robot id or a YAML value cannot forge a log line.
#pragma once

#include <atomic>
#include <mutex>
#include <string>

#include "locd/sdk/plugin.hpp"

namespace locd::server {

LogLevel parse_log_level(const std::string& name);  // debug|info|warning|error, else ConfigError
const char* log_level_name(LogLevel level);

class Logger {
 public:
  explicit Logger(LogLevel level = LogLevel::kInfo) : level_(level) {}
  void set_level(LogLevel level) { level_ = level; }
  bool enabled(LogLevel level) const { return level >= level_.load(); }
  // `subject` is a robot id, or "server" for events of the daemon itself.
  void log(LogLevel level, const std::string& subject, const std::string& message);

 private:
  std::atomic<LogLevel> level_;
  std::mutex mutex_;
};

}  // namespace locd::server
