#include "locd/server/log.hpp"

#include <chrono>
#include <cstdio>
#include <ctime>

#include "locd/sdk/text.hpp"

namespace locd::server {

LogLevel parse_log_level(const std::string& name) {
  if (name == "debug") return LogLevel::kDebug;
  if (name == "info") return LogLevel::kInfo;
  if (name == "warning") return LogLevel::kWarning;
  if (name == "error") return LogLevel::kError;
  throw ConfigError("log level '" + name + "' is not allowed; allowed: debug, info, warning, error");
}

const char* log_level_name(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug: return "debug";
    case LogLevel::kInfo: return "info";
    case LogLevel::kWarning: return "warning";
    case LogLevel::kError: return "error";
  }
  return "info";
}

void Logger::log(LogLevel level, const std::string& subject, const std::string& message) {
  if (!enabled(level)) return;
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto millis =
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%S", &utc);
  // One event, one line: text that came from the network (robot ids, YAML, plugin messages) is
  // escaped here, so nothing can forge or split a line.
  constexpr size_t kMaxLoggedMessage = 8192;
  const std::string safe_subject = escaped(subject, 64);
  const std::string safe_message = escaped(message, kMaxLoggedMessage);
  std::lock_guard<std::mutex> lock(mutex_);
  std::fprintf(stderr, "%s.%03dZ %s [%s] %s\n", stamp, static_cast<int>(millis), log_level_name(level),
               safe_subject.c_str(), safe_message.c_str());
  std::fflush(stderr);
}

}  // namespace locd::server
