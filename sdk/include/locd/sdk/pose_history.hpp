// The recent poses of a frame by stamp (a robot's odometry), for the pose at a given stamp:
// interpolated between the two samples around it (translation linearly, rotation by slerp), the
// newest sample when none is newer, nothing when every sample is newer. Bounded: the oldest
// samples go beyond `capacity`. Not thread-safe.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <optional>
#include <utility>

namespace locd {

class PoseHistory {
 public:
  explicit PoseHistory(size_t capacity = 512) : capacity_(capacity) {}

  // Samples arrive in stamp order; one older than the newest is ignored.
  void add(int64_t stamp_ns, const Eigen::Isometry3d& pose);
  std::optional<Eigen::Isometry3d> at(int64_t stamp_ns) const;
  size_t size() const { return samples_.size(); }
  // The stamps the history spans (call only when size() > 0).
  int64_t oldest_stamp() const { return samples_.front().first; }
  int64_t newest_stamp() const { return samples_.back().first; }

 private:
  size_t capacity_;
  std::deque<std::pair<int64_t, Eigen::Isometry3d>> samples_;
};

}  // namespace locd
