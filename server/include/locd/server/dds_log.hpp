// Cyclone DDS's own log lines into the server's log (subject "dds", escaped by the Logger): this
// is where a refused peer shows up, e.g. "Begin handshake reply failed: Certificate not valid:
// error: certificate has expired; subject: /CN=robot7/O=locd/OU=robot". Cyclone repeats a failed
// handshake every second; the same line is logged at most once per `repeat_period`, and the next
// one says how many were left out. Whatever the lines, at most kMaxLinesPerSecond are logged a
// second (a flood of peers cannot flood the log); the next line logged says how many were not.
#pragma once

#include <chrono>
#include <map>
#include <mutex>
#include <string>

#include "locd/dds/log_sink.hpp"
#include "locd/server/log.hpp"

namespace locd::server {

class DdsLogForwarder {
 public:
  static constexpr int kMaxLinesPerSecond = 20;

  explicit DdsLogForwarder(Logger& logger, std::chrono::seconds repeat_period = std::chrono::seconds(30));

  // What the sink does with one line (public for tests).
  void forward(dds::LogLevel level, const std::string& message);

 private:
  struct Seen {
    std::chrono::steady_clock::time_point logged;
    uint64_t left_out = 0;
  };
  Logger& logger_;
  std::chrono::steady_clock::duration repeat_period_;
  std::mutex mutex_;
  std::map<std::string, Seen> seen_;  // bounded: cleared when it holds kMaxLines
  std::chrono::steady_clock::time_point second_{};  // the current one-second window
  int lines_this_second_ = 0;
  uint64_t over_the_rate_ = 0;  // lines dropped by the rate limit, not yet reported
  dds::LogSink sink_;                 // last: installed once the rest exists
};

}  // namespace locd::server
