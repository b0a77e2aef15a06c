// The robot's end of a plugin's DDS test, in raw Cyclone DDS as a robot program in any language
// would speak it: a participant on the test's domain, the session-request writer, and readers
// of the robot's session status and poses. What the readers record sits under one mutex with one
// condition variable; a test's own readers (diagnostics, grids, goals, maps) record under the same
// lock and call notify(), so every wait is "until this predicate holds, or fail with locd's log".
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "child_process.hpp"
#include "locd/client/wire.hpp"
#include "locd/dds/convert.hpp"
#include "locd/dds/topics.hpp"

namespace locd::test {

class RobotSide {
 public:
  RobotSide(int domain, std::string robot_id, ChildProcess& locd,
            std::chrono::seconds timeout = std::chrono::seconds(30))
      : robot_id_(std::move(robot_id)),
        locd_(&locd),
        timeout_(timeout),
        participant_(domain),
        requests_(participant_, topics::kSessionRequest, dds::QosProfile::kState, 8, partition()),
        statuses_(participant_, topics::kSessionStatus, dds::QosProfile::kState,
                  [this](const locd_msg_SessionStatus& m) {
                    if (dds::to_string(m.robot_id) != robot_id_) return;
                    SessionStatus status = status_from_wire(m);
                    std::lock_guard<std::mutex> lock(mutex_);
                    status_ = std::move(status);
                    changed_.notify_all();
                  },
                  8, partition()),
        poses_(participant_, topics::kPose, dds::QosProfile::kPose, [this](const locd_msg_PoseEstimate& m) {
          if (dds::to_string(m.robot_id) != robot_id_) return;
          PoseEstimate p = dds::from_wire(m);
          std::lock_guard<std::mutex> lock(mutex_);
          poses_seen_.push_back(std::move(p));
          changed_.notify_all();
        }, 8, partition()) {}

  dds::Participant& participant() { return participant_; }
  // The locd this robot now talks to (after a test restarted it), for waits and logs.
  void set_server(ChildProcess& locd) { locd_ = &locd; }
  const std::string& robot_id() const { return robot_id_; }
  // The robot's DDS partition: every endpoint of the robot's side lives in it (topics.hpp).
  dds::Partitions partition() const { return {topics::robot_partition(robot_id_)}; }

  // Until locd has matched the request writer and every endpoint given (the test's own sensor
  // writers), or the timeout. The server writes a robot's outputs in its partition with writers
  // made for its session: readers of outputs match once the session has begun.
  template <class... Endpoints>
  ::testing::AssertionResult wait_matched(const Endpoints&... endpoints) {
    const auto deadline = std::chrono::steady_clock::now() + timeout_;
    while (requests_.matched() == 0 || ((endpoints.matched() == 0) || ...)) {
      if (std::chrono::steady_clock::now() > deadline || !locd_->running()) {
        return ::testing::AssertionFailure() << "locd did not come up:\n" << locd_->output();
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return ::testing::AssertionSuccess();
  }

  // Sends a start request and waits until the session runs.
  ::testing::AssertionResult start(const std::string& plugin, const std::string& config_yaml, uint64_t request_id = 1) {
    auto request = std::make_unique<locd_msg_SessionRequest>();
    std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
    dds::copy_string(request->robot_id, robot_id_);
    request->request_id = request_id;
    request->action = locd_msg_SESSION_START;
    dds::copy_string(request->plugin, plugin);
    dds::borrow_text(request->config_yaml, config_yaml, locd::topics::kMaxConfigYamlBytes);
    requests_.write(*request);
    std::unique_lock<std::mutex> lock(mutex_);
    return wait(lock, [&] { return status_.state == "running" && status_.request_id == request_id; }, "session running");
  }

  // With lock() held: waits until `done` holds; the failure names `what`, the status and locd's log.
  template <class Done>
  ::testing::AssertionResult wait(std::unique_lock<std::mutex>& lock, Done done, const std::string& what) {
    if (changed_.wait_for(lock, timeout_, done)) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "timed out waiting for " << what << "; poses " << poses_seen_.size()
                                         << ", last message '" << status_.message << "', last error '"
                                         << status_.last_error << "'\n"
                                         << locd_->output();
  }

  // Until the robot has received a pose stamped `stamp_ns`.
  ::testing::AssertionResult wait_pose(int64_t stamp_ns) {
    std::unique_lock<std::mutex> lock(mutex_);
    return wait(
        lock,
        [&] {
          for (auto it = poses_seen_.rbegin(); it != poses_seen_.rend(); ++it) {
            if (it->header.stamp_ns == stamp_ns) return true;
          }
          return false;
        },
        "a pose stamped " + std::to_string(stamp_ns));
  }

  // Until the status counts at least `count` rejected messages.
  ::testing::AssertionResult wait_rejected(uint64_t count) {
    std::unique_lock<std::mutex> lock(mutex_);
    return wait(lock, [&] { return status_.rejected >= count; }, std::to_string(count) + " rejected message(s)");
  }

  // Until the status says the plugin holds the initial pose stamped `stamp_ns` (DDS orders
  // samples per topic only: a test waits for this before sending what must meet the pose).
  ::testing::AssertionResult wait_initial_pose(int64_t stamp_ns) {
    std::unique_lock<std::mutex> lock(mutex_);
    return wait(lock, [&] { return status_.initial_pose_stamp_ns == stamp_ns; },
                "the initial pose stamped " + std::to_string(stamp_ns));
  }

  // The lock over everything recorded; a test's own reader callbacks take it too, then notify().
  std::unique_lock<std::mutex> lock() { return std::unique_lock<std::mutex>(mutex_); }
  std::mutex& mutex() { return mutex_; }
  void notify() { changed_.notify_all(); }

  // Read with lock() held.
  const SessionStatus& status() const { return status_; }
  const std::vector<PoseEstimate>& poses() const { return poses_seen_; }

  // Copies, taking the lock.
  SessionStatus status_now() {
    std::lock_guard<std::mutex> lock(mutex_);
    return status_;
  }
  size_t pose_count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return poses_seen_.size();
  }

 private:
  const std::string robot_id_;
  ChildProcess* locd_;
  const std::chrono::seconds timeout_;
  std::mutex mutex_;
  std::condition_variable changed_;
  SessionStatus status_;
  std::vector<PoseEstimate> poses_seen_;
  // Last: the readers' callbacks use the members above.
  dds::Participant participant_;
  dds::Writer<locd_msg_SessionRequest> requests_;
  dds::Reader<locd_msg_SessionStatus> statuses_;
  dds::Reader<locd_msg_PoseEstimate> poses_;
};

}  // namespace locd::test
