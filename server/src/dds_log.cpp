#include "locd/server/dds_log.hpp"

namespace locd::server {
namespace {

constexpr size_t kMaxLines = 1024;

LogLevel level_of(dds::LogLevel level) {
  switch (level) {
    case dds::LogLevel::kError: return LogLevel::kError;
    case dds::LogLevel::kWarning: return LogLevel::kWarning;
    case dds::LogLevel::kInfo: return LogLevel::kInfo;
  }
  return LogLevel::kInfo;
}

}  // namespace

DdsLogForwarder::DdsLogForwarder(Logger& logger, std::chrono::seconds repeat_period)
    : logger_(logger),
      repeat_period_(repeat_period),
      sink_([this](dds::LogLevel level, const std::string& message) { forward(level, message); }) {}

void DdsLogForwarder::forward(dds::LogLevel level, const std::string& message) {
  const auto now = std::chrono::steady_clock::now();
  uint64_t left_out = 0;
  uint64_t over_the_rate = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (now - second_ >= std::chrono::seconds(1)) {
      second_ = now;
      lines_this_second_ = 0;
    }
    if (lines_this_second_ >= kMaxLinesPerSecond) {
      ++over_the_rate_;
      return;
    }
    auto it = seen_.find(message);
    if (it != seen_.end() && now - it->second.logged < repeat_period_) {
      ++it->second.left_out;
      return;
    }
    if (it == seen_.end()) {
      if (seen_.size() >= kMaxLines) seen_.clear();
      it = seen_.emplace(message, Seen{}).first;
    }
    left_out = it->second.left_out;
    it->second = Seen{now, 0};
    ++lines_this_second_;
    over_the_rate = over_the_rate_;
    over_the_rate_ = 0;
  }
  std::string line = message;
  if (left_out > 0) line += " (and " + std::to_string(left_out) + " times more since the last line)";
  if (over_the_rate > 0) {
    line += " (" + std::to_string(over_the_rate) + " other DDS lines left out: more than " +
            std::to_string(kMaxLinesPerSecond) + " a second)";
  }
  logger_.log(level_of(level), "dds", line);
}

}  // namespace locd::server
