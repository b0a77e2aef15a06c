#include "locd/server/worker_launch.hpp"

#include <algorithm>
#include <cstring>

#include "locd/sdk/text.hpp"

namespace locd::server {

std::vector<std::string> worker_environment(char** environment) {
  static const char* const kExact[] = {"PATH", "LANG", "LC_ALL", "LC_NUMERIC", "LC_CTYPE", "TZ", "LD_LIBRARY_PATH"};
  static const char* const kPrefixes[] = {"OMP_", "OPENBLAS_", "MKL_", "TBB_", "OPENCV_"};
  std::vector<std::string> kept;
  for (char** e = environment; e && *e; ++e) {
    const std::string entry(*e);
    const size_t equals = entry.find('=');
    if (equals == std::string::npos) continue;
    const std::string name = entry.substr(0, equals);
    bool allowed = std::any_of(std::begin(kExact), std::end(kExact), [&](const char* n) { return name == n; });
    for (const char* prefix : kPrefixes) allowed = allowed || name.rfind(prefix, 0) == 0;
    if (allowed) kept.push_back(entry);
  }
  return kept;
}

void append_sandbox_arguments(std::vector<std::string>& arguments, const SandboxPaths& paths) {
  arguments.push_back("--sandbox");
  arguments.push_back(paths.enabled ? "on" : "off");
  for (const auto& dir : paths.readable) {
    arguments.push_back("--read");
    arguments.push_back(dir.string());
  }
  if (!paths.writable.empty()) {
    arguments.push_back("--write");
    arguments.push_back(paths.writable.string());
  }
}

StderrLines::StderrLines(std::string who, Logger& logger)
    : who_(std::move(who)), logger_(logger), refilled_(std::chrono::steady_clock::now()) {}

void StderrLines::append(const char* data, size_t bytes) {
  for (size_t i = 0; i < bytes; ++i) {
    if (data[i] == '\n') {
      line(partial_);
      partial_.clear();
      partial_dropped_ = 0;
    } else if (partial_.size() < kMaxLineBytes) {
      partial_ += data[i];
    } else {
      ++partial_dropped_;
    }
  }
}

void StderrLines::finish() {
  if (!partial_.empty()) line(partial_);
  partial_.clear();
  partial_dropped_ = 0;
  if (suppressed_ > 0) {
    logger_.log(LogLevel::kWarning, "server",
                who_ + ": " + std::to_string(suppressed_) + " more line(s) of stderr not logged (rate limit)");
    suppressed_ = 0;
  }
}

void StderrLines::line(const std::string& text) {
  const auto now = std::chrono::steady_clock::now();
  tokens_ = std::min(kBurstLines, tokens_ + kLinesPerSecond * std::chrono::duration<double>(now - refilled_).count());
  refilled_ = now;
  if (tokens_ < 1.0) {
    ++suppressed_;
    ++suppressed_total_;
    return;
  }
  tokens_ -= 1.0;
  if (suppressed_ > 0) {
    logger_.log(LogLevel::kWarning, "server",
                who_ + ": " + std::to_string(suppressed_) + " line(s) of stderr not logged (rate limit)");
    suppressed_ = 0;
  }
  std::string shown = escaped(text, kMaxLineBytes);
  if (partial_dropped_ > 0) shown += "...(" + std::to_string(partial_dropped_) + " more bytes)";
  ++logged_;
  // Quoted and escaped: whatever the plugin wrote reads as its text, never as a line of locd's.
  logger_.log(LogLevel::kWarning, "server", who_ + " wrote to stderr: \"" + shown + "\"");
}

}  // namespace locd::server
