// An OutputSink that records what sessions publish, for tests that wait for asynchronous work.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "locd/server/output_sink.hpp"

namespace locd::server::test {

struct PublishedOutputs {
  std::string robot_id, plugin;
  Header header;
  UpdateResult result;
};

class RecordingSink : public OutputSink {
 public:
  void publish_status(const SessionStatusReport& status) override {
    std::lock_guard<std::mutex> lock(mutex_);
    statuses_.push_back(status);
    changed_.notify_all();
  }
  void publish_outputs(const std::string& robot_id, const std::string& plugin, const Header& header,
                       const UpdateResult& result, double) override {
    std::lock_guard<std::mutex> lock(mutex_);
    outputs_.push_back({robot_id, plugin, header, result});
    changed_.notify_all();
  }
  void publish_server_info(const ServerInfoReport& info) override {
    std::lock_guard<std::mutex> lock(mutex_);
    infos_.push_back(info);
    changed_.notify_all();
  }

  // Waits (at most `timeout`) until `done` holds over the recorded statuses and outputs.
  bool wait_for(const std::function<bool(const std::vector<SessionStatusReport>&, const std::vector<PublishedOutputs>&)>& done,
                std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return done(statuses_, outputs_); });
  }
  // The newest status for a robot matching `pred`, waiting for it.
  std::optional<SessionStatusReport> wait_status(const std::string& robot_id,
                                                 const std::function<bool(const SessionStatusReport&)>& pred) {
    std::optional<SessionStatusReport> found;
    wait_for([&](const auto& statuses, const auto&) {
      for (auto it = statuses.rbegin(); it != statuses.rend(); ++it) {
        if (it->robot_id == robot_id && pred(*it)) {
          found = *it;
          return true;
        }
      }
      return false;
    });
    return found;
  }
  std::vector<PublishedOutputs> outputs() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return outputs_;
  }
  std::vector<ServerInfoReport> infos() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return infos_;
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<SessionStatusReport> statuses_;
  std::vector<PublishedOutputs> outputs_;
  std::vector<ServerInfoReport> infos_;
};

}  // namespace locd::server::test
