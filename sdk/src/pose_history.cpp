#include "locd/sdk/pose_history.hpp"

#include <algorithm>

namespace locd {

void PoseHistory::add(int64_t stamp_ns, const Eigen::Isometry3d& pose) {
  if (!samples_.empty() && stamp_ns < samples_.back().first) return;
  samples_.emplace_back(stamp_ns, pose);
  while (samples_.size() > capacity_) samples_.pop_front();
}

std::optional<Eigen::Isometry3d> PoseHistory::at(int64_t stamp_ns) const {
  if (samples_.empty() || stamp_ns < samples_.front().first) return std::nullopt;
  if (stamp_ns >= samples_.back().first) return samples_.back().second;
  // The first sample newer than the stamp, and the one before it.
  const auto after = std::upper_bound(samples_.begin(), samples_.end(), stamp_ns,
                                      [](int64_t stamp, const auto& sample) { return stamp < sample.first; });
  const auto before = std::prev(after);
  const double t = static_cast<double>(stamp_ns - before->first) / static_cast<double>(after->first - before->first);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = (1.0 - t) * before->second.translation() + t * after->second.translation();
  pose.linear() = Eigen::Quaterniond(before->second.linear())
                      .slerp(t, Eigen::Quaterniond(after->second.linear()))
                      .toRotationMatrix();
  return pose;
}

}  // namespace locd
