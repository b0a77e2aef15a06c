// A locd child process for integration tests: a temp folder holding its config (and a `maps`
// subfolder), the server serving its own domain, stopped at the end and the folder removed
// unless the test failed (then the config and locd.log stay for reading).
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "test_env.hpp"

namespace locd::test {

struct TestServerOptions {
  std::string map_directories;  // YAML list body; default: the tree's config/maps
  std::string extra_config;     // more lines of locd.yaml (e.g. "output_directory: maps\n")
  int queue_depth = 1000;
  std::string extra_plugin_directory;  // besides the tree's plugins (e.g. the broken plugins)
  std::vector<std::string> environment;  // "NAME=value" for locd, e.g. a secure CYCLONEDDS_URI
};

class TestServer {
 public:
  TestServer(const std::string& name, int domain, const TestServerOptions& options = {}) {
    dir_ = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()) + "_" + std::to_string(domain));
    std::filesystem::create_directories(dir_ / "maps");
    std::ofstream(dir_ / "locd.yaml")
        << "server_id: " << name << "-" << domain << "\n"
        << "domain_id: " << domain << "\n"
        << "plugin_directories: [" << plugin_dir()
        << (options.extra_plugin_directory.empty() ? "" : ", " + options.extra_plugin_directory) << "]\n"
        << "map_directories: ["
        << (options.map_directories.empty() ? source_dir() + "/config/maps" : options.map_directories) << "]\n"
        << "status_period_s: 0.2\n"
        << "queue_depth: " << options.queue_depth << "\n"
        << options.extra_config;
    start(options.environment);
  }
  // Starts locd again on the same config (after the last one ended); its log goes to
  // locd.<n>.log, n counting the restarts.
  void restart() {
    ++starts_;
    start(environment_);
  }
  ~TestServer() {
    if (process_->running()) {
      process_->signal(SIGTERM);
      process_->wait(std::chrono::seconds(10));
    }
    std::error_code ec;
    if (!::testing::Test::HasFailure()) std::filesystem::remove_all(dir_, ec);
  }
  TestServer(const TestServer&) = delete;
  TestServer& operator=(const TestServer&) = delete;

  const std::filesystem::path& dir() const { return dir_; }
  ChildProcess& process() { return *process_; }

 private:
  void start(const std::vector<std::string>& environment) {
    environment_ = environment;
    const std::string log = starts_ == 0 ? "locd.log" : "locd." + std::to_string(starts_) + ".log";
    process_ = std::make_unique<ChildProcess>(binary_dir() + "/bin/locd",
                                              std::vector<std::string>{"--config", (dir_ / "locd.yaml").string()},
                                              (dir_ / log).string(), environment);
  }

  std::filesystem::path dir_;
  int starts_ = 0;
  std::vector<std::string> environment_;
  std::unique_ptr<ChildProcess> process_;
};

}  // namespace locd::test
