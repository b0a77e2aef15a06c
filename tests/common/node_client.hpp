// Runs the test-only Node.js clients (tests/node/*.mjs, copied into build/node with the npm
// packages scripts/node-setup installs there). When the packages are missing the test fails
// naming the setup script and its log: it never skips.
#pragma once

#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "test_env.hpp"

namespace locd::test {

inline std::string node_directory() { return binary_dir() + "/node"; }

inline void require_node_packages() {
  const std::string dir = node_directory();
  if (!std::filesystem::exists(dir + "/node_modules/@mcap/core") ||
      !std::filesystem::exists(dir + "/node_modules/@foxglove/ws-protocol") ||
      !std::filesystem::exists(dir + "/node_modules/@foxglove/rosmsg2-serialization")) {
    throw std::runtime_error("the npm test clients are not installed in " + dir +
                             "/node_modules: run scripts/node-setup (npm registry needed; log in " + dir + "/npm.log)");
  }
}

inline std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// Runs `node build/node/<script> args...`; stdout is returned, stderr goes to the test's log.
inline std::string run_node(const std::string& script, const std::vector<std::string>& args, int& exit_code) {
  require_node_packages();
  std::string command = "node " + shell_quote(node_directory() + "/" + script);
  for (const auto& a : args) command += " " + shell_quote(a);
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) throw std::runtime_error("cannot run " + command);
  std::string out;
  char buffer[4096];
  for (size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) out.append(buffer, n);
  const int status = pclose(pipe);
  exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

// One JSON object per output line.
inline std::vector<nlohmann::json> json_lines(const std::string& text) {
  std::vector<nlohmann::json> out;
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    if (end > start) out.push_back(nlohmann::json::parse(text.substr(start, end - start)));
    start = end + 1;
  }
  return out;
}

}  // namespace locd::test
