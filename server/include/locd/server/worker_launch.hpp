// How locd starts locd-worker processes (plugin workers and plugin inspectors) and treats what
// they write outside the worker protocol. A worker is untrusted: it gets an environment with no
// DDS identity and no secrets (an allow-list), the sandbox arguments that confine it
// (worker_sandbox.hpp), and its stderr is text from outside: split into lines, each escaped and
// bounded, and rate-limited before it reaches locd's log.
#pragma once

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "locd/server/log.hpp"

namespace locd::server {

// The variables of `environment` (NAME=value) a worker may see: locale, time zone, the dynamic
// loader's path and the thread-count knobs of the numeric libraries (OMP_, OPENBLAS_, TBB_, ...).
// Everything else is dropped, CYCLONEDDS_URI, LOCD_IDENTITY and any other secret among it.
std::vector<std::string> worker_environment(char** environment);

// What a worker may touch, passed as arguments (--sandbox, --read, --write).
struct SandboxPaths {
  bool enabled = true;                         // false: no Landlock, seccomp or capability drop
  std::vector<std::filesystem::path> readable;  // plugin and map directories (system libraries are added by the worker)
  std::filesystem::path writable;              // output directory; empty: nowhere
};
void append_sandbox_arguments(std::vector<std::string>& arguments, const SandboxPaths& paths);

// A worker's stderr on its way into the log: complete lines, each escaped and cut at
// kMaxLineBytes, at most kBurstLines in a burst and kLinesPerSecond after that; lines over the
// rate are counted and the count logged when lines flow again (or at finish()).
class StderrLines {
 public:
  static constexpr size_t kMaxLineBytes = 512;
  static constexpr double kBurstLines = 20.0;
  static constexpr double kLinesPerSecond = 5.0;

  // `who` names the process in every line ("plugin 'x' (worker pid 12)").
  StderrLines(std::string who, Logger& logger);
  void append(const char* data, size_t bytes);
  void finish();  // a last unterminated line, and the suppressed count
  size_t logged() const { return logged_; }
  size_t suppressed_total() const { return suppressed_total_; }

 private:
  void line(const std::string& text);
  std::string who_;
  Logger& logger_;
  std::string partial_;
  size_t partial_dropped_ = 0;  // bytes of an overlong line beyond what is kept
  double tokens_ = kBurstLines;
  std::chrono::steady_clock::time_point refilled_;
  size_t suppressed_ = 0, suppressed_total_ = 0, logged_ = 0;
};

}  // namespace locd::server
