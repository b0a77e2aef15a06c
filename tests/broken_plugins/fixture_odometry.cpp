// A good fixture plugin for the loader and server tests (never installed): the pose is the
// odometry pose composed onto the pose given by set_pose, T_map_base = T_map_odom * T_odom_base,
// with T_map_odom fixed at the first odometry after the pose is set. Scans are checked (an
// all-NaN or empty scan is an InputError) and counted, but do not correct the pose.
//
// Built a second time with LOCD_FAULTY as the plugin `faulty`: the same localizer that misbehaves
// on request, for the fault-isolation tests. Its extra parameters:
//   fault: none | segfault | abort | exit | hang | allocate | stack_overflow | garbage | throw |
//          nan_pose | bad_covariance | fork_busy_child (once: forks a child that spins for ever,
//          logs its pid, and carries on well)
//   fault_in: update | configure | set_pose    (where the fault strikes; default update)
//   after_updates: N                           (odometry updates that go well first; default 0)
//   work_ms: T                                 (each update takes at least T ms; default 0)
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "locd/sdk/plugin.hpp"

namespace {

#ifdef LOCD_FAULTY
// The channel to locd in a worker process (locd-worker --channel-fd).
constexpr int kWorkerChannelFd = 3;

// Deep enough to exhaust any stack.
int recurse(int depth) {
  volatile char frame[64 * 1024];
  frame[0] = static_cast<char>(depth);
  return recurse(depth + 1) + frame[0];
}

[[noreturn]] void hang() {
  for (volatile bool forever = true; forever;) {
  }
  std::abort();
}

void allocate_without_end() {
  constexpr size_t kChunk = 64u << 20;
  std::vector<std::unique_ptr<char[]>> hoard;
  for (;;) {
    hoard.emplace_back(new char[kChunk]);
    std::memset(hoard.back().get(), 1, kChunk);
  }
}
#endif

class OdometryFixture : public locd::Localizer {
 public:
  void configure([[maybe_unused]] const locd::PluginContext& context, const locd::Params& params) override {
#ifdef LOCD_FAULTY
    params.expect_only({"position_stddev", "fault", "fault_in", "after_updates", "work_ms"});
    fault_ = params.text("fault", "none",
                         {"none", "segfault", "abort", "exit", "hang", "allocate", "stack_overflow", "garbage", "throw",
                          "nan_pose", "bad_covariance", "fork_busy_child"});
    log_ = context.log;
    fault_in_ = params.text("fault_in", "update", {"update", "configure", "set_pose"});
    after_updates_ = params.integer("after_updates", 0, 0, 1'000'000'000);
    work_ms_ = params.number("work_ms", 0.0, locd::Range::closed(0.0, 60'000.0));
    if (fault_in_ == "configure") strike();
#else
    params.expect_only({"position_stddev"});
#endif
    position_stddev_ = params.number("position_stddev", 0.1, locd::Range::positive());
  }

  void set_pose(const locd::PoseEstimate& pose) override {
#ifdef LOCD_FAULTY
    if (fault_in_ == "set_pose") strike();
#endif
    map_from_base_ = pose.pose;
    pose_set_ = true;
  }

  locd::UpdateResult update(const locd::Measurement& measurement) override {
    locd::UpdateResult result;
    if (const auto* scan = std::get_if<locd::LaserScan>(&measurement)) {
      size_t returns = 0;
      for (size_t i = 0; i < scan->ranges.size(); ++i) returns += scan->valid_return(i);
      if (returns == 0) throw locd::InputError("scan has no valid return");
      ++scans_;
      result.diagnostics.values.push_back({"scans", static_cast<double>(scans_)});
      return result;
    }
    const auto* odometry = std::get_if<locd::Odometry>(&measurement);
    if (!odometry) throw locd::InputError("fixture_odometry consumes odometry and scans only");
#ifdef LOCD_FAULTY
    if (work_ms_ > 0.0) std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(work_ms_));
    const bool strike_now = fault_in_ == "update" && updates_++ >= after_updates_;
    if (strike_now) strike();
#endif
    if (!odom_known_ || pose_set_) {
      // Anchor: map_from_odom maps the current odometry pose onto the current map pose.
      map_from_odom_ = map_from_base_ * odometry->pose.inverse();
      odom_known_ = true;
      pose_set_ = false;
    }
    map_from_base_ = map_from_odom_ * odometry->pose;
    locd::PoseEstimate estimate;
    estimate.header = {odometry->header.stamp_ns, "map"};
    estimate.pose = map_from_base_;
    estimate.covariance = locd::Matrix6d::Identity() * position_stddev_ * position_stddev_;
#ifdef LOCD_FAULTY
    if (strike_now && fault_ == "nan_pose") estimate.pose.translation().x() = std::numeric_limits<double>::quiet_NaN();
    if (strike_now && fault_ == "bad_covariance") estimate.covariance(0, 0) = -1.0;
#endif
    result.estimate = estimate;
    return result;
  }

 private:
#ifdef LOCD_FAULTY
  // The faults that end the process or break its channel; the others act on the estimate.
  void strike() {
    if (fault_ == "segfault") *reinterpret_cast<volatile int*>(static_cast<std::uintptr_t>(8)) = 1;
    if (fault_ == "abort") std::abort();
    if (fault_ == "exit") std::exit(3);
    if (fault_ == "hang") hang();
    if (fault_ == "allocate") allocate_without_end();
    if (fault_ == "stack_overflow") recurse(0);
    if (fault_ == "throw") throw std::runtime_error("faulty: thrown on purpose");
    if (fault_ == "fork_busy_child" && !forked_) {
      forked_ = true;
      const pid_t child = ::fork();
      if (child == 0) {
        for (volatile bool forever = true; forever;) {
        }
        ::_exit(0);
      }
      log_(locd::LogLevel::kWarning, "faulty: forked a busy child, pid " + std::to_string(child));
    }
    if (fault_ == "garbage") {
      const char junk[] = "this is not a frame of the worker protocol, just bytes a plugin wrote";
      [[maybe_unused]] const ssize_t n = ::write(kWorkerChannelFd, junk, sizeof junk);
    }
  }

  std::string fault_ = "none";
  std::string fault_in_ = "update";
  long after_updates_ = 0;
  long updates_ = 0;
  double work_ms_ = 0.0;
  bool forked_ = false;
  std::function<void(locd::LogLevel, const std::string&)> log_;
#endif
  double position_stddev_ = 0.1;
  Eigen::Isometry3d map_from_base_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d map_from_odom_ = Eigen::Isometry3d::Identity();
  bool pose_set_ = false;
  bool odom_known_ = false;
  size_t scans_ = 0;
};

}  // namespace

#ifdef LOCD_FAULTY
LOCD_REGISTER_PLUGIN(OdometryFixture, "faulty", "0.1.0",
                     "test fixture: fixture_odometry that crashes, exits, hangs, hoards memory or lies on request",
                     locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kLaserScan))
#else
LOCD_REGISTER_PLUGIN(OdometryFixture, "fixture_odometry", "0.1.0",
                     "test fixture: odometry composed onto the set pose",
                     locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kLaserScan))
#endif
