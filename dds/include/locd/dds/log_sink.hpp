// Cyclone DDS's own log (errors, warnings, info: e.g. a refused security handshake naming the
// peer's certificate subject and the cause, or a participant whose permissions expired) handed to
// a callback instead of Cyclone's default, stderr. Trace categories stay off.
#pragma once

#include <functional>
#include <string>

namespace locd::dds {

enum class LogLevel { kError, kWarning, kInfo };

class LogSink {
 public:
  // `message` is one line without Cyclone's time/domain/thread header and without the newline.
  // The callback runs on Cyclone's threads (and on the thread of a failing DDS call): it must
  // not call into DDS.
  using Callback = std::function<void(LogLevel level, const std::string& message)>;

  // Installs the sink for the whole process; only one LogSink may exist at a time.
  explicit LogSink(Callback callback);
  // Restores Cyclone's default sink (waits until no thread uses this one).
  ~LogSink();
  LogSink(const LogSink&) = delete;
  LogSink& operator=(const LogSink&) = delete;

 private:
  Callback callback_;
};

}  // namespace locd::dds
