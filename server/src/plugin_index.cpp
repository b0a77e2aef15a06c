#include "locd/server/plugin_index.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <regex>
#include <set>

#include "locd/sdk/errors.hpp"
#include "locd/sdk/text.hpp"

extern char** environ;

namespace locd::server {
namespace fs = std::filesystem;

namespace {

bool printable(std::string_view text) {
  return std::all_of(text.begin(), text.end(), [](char c) { return c >= 0x20 && c <= 0x7e; });
}

}  // namespace

PluginDescription parse_inspection(std::string_view output, const fs::path& file, uint32_t supported_kinds) {
  auto fail = [&](const std::string& cause) -> void {
    throw PluginLoadError(file.string() + ": its inspection " + cause);
  };
  if (output.size() > kMaxInspectionBytes) {
    fail("printed " + std::to_string(output.size()) + " bytes, more than " + std::to_string(kMaxInspectionBytes));
  }
  std::vector<std::string_view> lines;
  for (size_t start = 0; start < output.size();) {
    const size_t end = output.find('\n', start);
    if (end == std::string_view::npos) fail("ends without a newline");
    lines.push_back(output.substr(start, end - start));
    start = end + 1;
  }
  if (lines.empty() || lines.front() != "locd-plugin-inspection 1") {
    fail("does not start with 'locd-plugin-inspection 1' (got '" +
         escaped(lines.empty() ? std::string_view() : lines.front(), 64) + "')");
  }
  PluginDescription d;
  d.file = file;
  std::set<std::string> seen;
  bool consumes_seen = false;
  for (size_t i = 1; i < lines.size(); ++i) {
    const std::string_view line = lines[i];
    const size_t space = line.find(' ');
    const std::string key(line.substr(0, space));
    const std::string_view value = space == std::string_view::npos ? std::string_view() : line.substr(space + 1);
    if (!seen.insert(key).second) fail("names '" + escaped(key, 32) + "' twice");
    if (!printable(value)) fail("line " + std::to_string(i + 1) + " holds bytes that are not printable ASCII");
    if (key == "name") {
      static const std::regex valid_name("[a-z][a-z0-9_]{0,63}");
      if (!std::regex_match(value.begin(), value.end(), valid_name)) {
        fail("gives an invalid plugin name '" + escaped(value, 80) + "'; expected [a-z][a-z0-9_]{0,63}");
      }
      d.name = std::string(value);
    } else if (key == "version") {
      if (value.size() > kMaxPluginVersionBytes) fail("gives a version longer than " + std::to_string(kMaxPluginVersionBytes) + " bytes");
      d.version = std::string(value);
    } else if (key == "description") {
      if (value.size() > kMaxPluginDescriptionBytes) {
        fail("gives a description longer than " + std::to_string(kMaxPluginDescriptionBytes) + " bytes");
      }
      d.description = std::string(value);
    } else if (key == "consumes") {
      const std::string text(value);
      char* end = nullptr;
      errno = 0;
      const unsigned long long bits = std::strtoull(text.c_str(), &end, 10);
      if (text.empty() || *end != '\0' || errno != 0 || bits > 0xffffffffull || text[0] == '-') {
        fail("gives consumes '" + escaped(text, 32) + "'; expected a 32-bit decimal");
      }
      d.consumes = static_cast<uint32_t>(bits);
      consumes_seen = true;
    } else {
      fail("has an unknown key '" + escaped(key, 32) + "' on line " + std::to_string(i + 1));
    }
  }
  if (d.name.empty()) fail("gives no name");
  if (!seen.count("version")) fail("gives no version");
  if (!consumes_seen || d.consumes == 0) throw PluginLoadError(file.string() + ": plugin '" + d.name + "' consumes no measurement kind");
  if (d.consumes & ~supported_kinds) {
    std::string names;
    for (const auto& n : kind_names(d.consumes & ~supported_kinds)) names += (names.empty() ? "" : ", ") + n;
    if (names.empty()) names = "unknown kind bits " + std::to_string(d.consumes & ~supported_kinds);
    throw PluginLoadError(file.string() + ": plugin '" + d.name + "' needs inputs this server cannot give: " + names);
  }
  return d;
}

PluginDescription inspect_plugin(const fs::path& file, const InspectorSettings& settings, Logger& logger,
                                 uint32_t supported_kinds) {
  const std::string where = file.string();
  int out[2], err[2];
  if (pipe2(out, O_CLOEXEC) != 0) throw PluginLoadError(where + ": cannot inspect: pipe: " + std::strerror(errno));
  if (pipe2(err, O_CLOEXEC) != 0) {
    const int e = errno;
    close(out[0]);
    close(out[1]);
    throw PluginLoadError(where + ": cannot inspect: pipe: " + std::strerror(e));
  }
  const std::string exe = settings.executable.string();
  std::vector<std::string> arguments = {exe, "--inspect", where, "--memory-limit-mb",
                                        std::to_string(settings.memory_limit_mb)};
  SandboxPaths sandbox = settings.sandbox;
  sandbox.writable.clear();  // an inspector writes nowhere
  append_sandbox_arguments(arguments, sandbox);
  std::vector<char*> argv;
  for (auto& a : arguments) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> environment = worker_environment(environ);
  std::vector<char*> envp;
  for (auto& e : environment) envp.push_back(e.data());
  envp.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, err[1], STDERR_FILENO);
  posix_spawn_file_actions_addclosefrom_np(&actions, STDERR_FILENO + 1);
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, exe.c_str(), &actions, &attributes, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  close(out[1]);
  close(err[1]);
  if (rc != 0) {
    close(out[0]);
    close(err[0]);
    throw PluginLoadError(where + ": cannot start the inspector '" + exe + "': " + std::strerror(rc));
  }

  StderrLines stderr_lines("inspector of " + where + " (pid " + std::to_string(pid) + ")", logger);
  std::string output;
  bool too_long = false, timed_out = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(settings.timeout_s);
  pollfd fds[2] = {{out[0], POLLIN, 0}, {err[0], POLLIN, 0}};
  while (fds[0].fd >= 0 || fds[1].fd >= 0) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out = true;
      break;
    }
    const int ready = poll(fds, 2, static_cast<int>(std::min<long long>(left.count(), 1000)));
    if (ready < 0 && errno != EINTR) break;
    char chunk[4096];
    for (auto& fd : fds) {
      if (fd.fd < 0 || !(fd.revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const ssize_t n = ::read(fd.fd, chunk, sizeof chunk);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        close(fd.fd);
        fd.fd = -1;
        continue;
      }
      if (&fd == &fds[1]) {
        stderr_lines.append(chunk, static_cast<size_t>(n));
      } else if (output.size() + static_cast<size_t>(n) > kMaxInspectionBytes) {
        too_long = true;
      } else {
        output.append(chunk, static_cast<size_t>(n));
      }
    }
    if (too_long) break;
  }
  if (timed_out || too_long) ::kill(-pid, SIGKILL);
  for (auto& fd : fds) {
    if (fd.fd >= 0) close(fd.fd);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  ::kill(-pid, SIGKILL);  // whatever it forked
  stderr_lines.finish();
  if (timed_out) throw PluginLoadError(where + ": its inspection did not end within " + std::to_string(settings.timeout_s) + " s");
  if (too_long) {
    throw PluginLoadError(where + ": its inspection printed more than " + std::to_string(kMaxInspectionBytes) + " bytes");
  }
  if (WIFSIGNALED(status)) {
    throw PluginLoadError(where + ": its inspection was killed by signal " + std::to_string(WTERMSIG(status)) +
                          " (the plugin crashed while loading)");
  }
  if (WEXITSTATUS(status) != 0) {
    // The inspector's refusal: one line "error TEXT" (escaped by the inspector, bounded here).
    const std::string marker = "error ";
    const size_t at = output.rfind(marker);
    if (at != std::string::npos) {
      const size_t end = output.find('\n', at);
      const std::string text = output.substr(at + marker.size(), end == std::string::npos ? std::string::npos : end - at - marker.size());
      std::string cause = escaped(text, 1024);
      // The inspector names the file itself; say it once.
      if (cause.rfind(where + ": ", 0) == 0) cause = cause.substr(where.size() + 2);
      throw PluginLoadError(where + ": " + cause);
    }
    throw PluginLoadError(where + ": its inspection exited with code " + std::to_string(WEXITSTATUS(status)));
  }
  return parse_inspection(output, file, supported_kinds);
}

PluginIndex::PluginIndex(const std::vector<fs::path>& directories, const InspectorSettings& settings, Logger& logger,
                         uint32_t supported_kinds) {
  scan(directories, [&](const fs::path& file) {
    auto description = std::make_shared<const PluginDescription>(inspect_plugin(file, settings, logger, supported_kinds));
    return std::make_pair(description->name, description);
  });
}

}  // namespace locd::server
