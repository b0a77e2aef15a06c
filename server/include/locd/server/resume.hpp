// Where a session resumes after its plugin restarts, after a plugin switch, and after the server
// itself restarts (kill -9 included): the robot's last estimate and, for a robot that sends
// odometry, the map -> odom transform at that estimate. The resumed pose is that transform
// applied to the odometry the plugin takes next, so it follows the robot over the gap.
//
// Across server restarts the states live in a small file in the server's `state_directory`
// (written once per status period, atomically). DDS cannot hold them for a lone server: a
// transient-local writer's data dies with its process.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "locd/sdk/types.hpp"
#include "locd/server/log.hpp"

namespace locd::server {

struct ResumeState {
  PoseEstimate estimate;                           // last published, stamped with its measurement
  std::optional<Eigen::Isometry3d> map_from_odom;  // estimate.pose * odometry(stamp)^-1
  std::string plugin;
  uint64_t request_id = 0;  // the session request whose plugin produced it
  bool failed = false;      // that request's plugin failed max_failures times and was stopped
  std::string server;       // the server whose session it comes from (another one's, on a takeover)
  int32_t claim_strength = 0;  // of the claim it was served under (fleet.hpp); the state file keeps it
};

// The odometry pose at `stamp_ns`, carried from `latest` with its body velocities, forwards or
// backwards (the newest odometry may be a little younger than a scan still queued); nothing when
// the gap exceeds kMaxOdometryExtrapolationNs either way.
inline constexpr int64_t kMaxOdometryExtrapolationNs = 1'000'000'000;
std::optional<Eigen::Isometry3d> odometry_at(const Odometry& latest, int64_t stamp_ns);

// map_from_odom of an estimate, from the latest odometry given to the plugin before it.
std::optional<Eigen::Isometry3d> map_from_odom(const PoseEstimate& estimate, const Odometry& latest);

// The pose to resume from when the plugin takes `next_odometry` as its first odometry (null: none
// known): map_from_odom * next_odometry, stamped with it; else the last estimate as it was. An
// odometry older than the estimate (a robot whose clock began again) is not trusted.
PoseEstimate resume_pose(const ResumeState& state, const Odometry* next_odometry);

// The state file `<directory>/sessions.json`. A default-constructed StateFile is disabled.
class StateFile {
 public:
  StateFile() = default;
  explicit StateFile(std::filesystem::path directory);
  bool enabled() const { return !directory_.empty(); }
  const std::filesystem::path& file() const { return file_; }

  // Every robot's state. A missing file is empty; an unreadable or malformed one, or one larger
  // than kMaxStateFileBytes, is logged and ignored; a bad entry is logged and skipped.
  std::map<std::string, ResumeState> load(Logger& logger) const;
  // The file's text for `states`.
  static std::string encode(const std::map<std::string, ResumeState>& states);
  // Writes `<file>.tmp` and renames it over the file. Throws std::runtime_error on I/O errors.
  void write(const std::string& text) const;

  static constexpr size_t kMaxStateFileBytes = 64u << 20;

 private:
  std::filesystem::path directory_;
  std::filesystem::path file_;
};

}  // namespace locd::server
