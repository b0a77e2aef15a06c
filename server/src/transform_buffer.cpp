#include "locd/server/transform_buffer.hpp"

#include <algorithm>
#include <sstream>

namespace locd::server {
namespace {

std::string seconds(int64_t stamp_ns) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(3);
  out << static_cast<double>(stamp_ns) * 1e-9 << " s";
  return out.str();
}

}  // namespace

void TransformBuffer::add(const dds::ros2::StampedTransform& t, bool is_static) {
  if (!is_static && t.stamp_ns == 0) {
    throw InputError("transform '" + t.parent + "' -> '" + t.child + "' on tf has a zero stamp");
  }
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = links_.find(t.child);
  if (it == links_.end()) {
    if (links_.size() >= kMaxFrames) return;
    it = links_.emplace(t.child, Link{}).first;
  }
  Link& link = it->second;
  if (link.parent != t.parent || link.is_static != is_static) link.samples = PoseHistory(kSamplesPerLink);
  link.parent = t.parent;
  link.is_static = is_static;
  if (is_static) {
    link.parent_from_child = t.parent_from_child;
  } else {
    link.samples.add(t.stamp_ns, t.parent_from_child);
  }
}

std::vector<std::string> TransformBuffer::chain_of(const std::string& frame) const {
  std::vector<std::string> chain{frame};
  for (int i = 0; i < kMaxChain; ++i) {
    const auto it = links_.find(chain.back());
    if (it == links_.end()) return chain;
    chain.push_back(it->second.parent);
  }
  throw InputError("frame '" + frame + "': its chain on tf is longer than " + std::to_string(kMaxChain) +
                   " links (a loop?)");
}

Eigen::Isometry3d TransformBuffer::along(const std::vector<std::string>& chain, size_t to, int64_t stamp) const {
  Eigen::Isometry3d ancestor_from_frame = Eigen::Isometry3d::Identity();
  for (size_t i = 0; i < to; ++i) {
    const Link& link = links_.at(chain[i]);
    Eigen::Isometry3d parent_from_child = link.parent_from_child;
    if (!link.is_static) {
      if (link.samples.size() == 0 || stamp < link.samples.oldest_stamp() || stamp > link.samples.newest_stamp()) {
        std::string held = link.samples.size() == 0
                               ? "none"
                               : seconds(link.samples.oldest_stamp()) + " to " + seconds(link.samples.newest_stamp());
        throw InputError("transform '" + link.parent + "' -> '" + chain[i] + "' on tf has no sample around the stamp " +
                         seconds(stamp) + " (it holds " + held + "); tf2 does not extrapolate");
      }
      parent_from_child = *link.samples.at(stamp);
    }
    ancestor_from_frame = parent_from_child * ancestor_from_frame;
  }
  return ancestor_from_frame;
}

Eigen::Isometry3d TransformBuffer::pose_in(const std::string& target, const std::string& frame, int64_t stamp) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!links_.count(frame) && !links_.count(target)) {
    throw InputError("frame '" + frame + "' is on neither /tf_static nor /tf (and ros2.sensor_frames is not given): "
                     "its pose in '" + target + "' is unknown");
  }
  const std::vector<std::string> up_from_frame = chain_of(frame);
  const std::vector<std::string> up_from_target = chain_of(target);
  for (size_t i = 0; i < up_from_frame.size(); ++i) {
    const auto common = std::find(up_from_target.begin(), up_from_target.end(), up_from_frame[i]);
    if (common == up_from_target.end()) continue;
    const size_t j = static_cast<size_t>(common - up_from_target.begin());
    return along(up_from_target, j, stamp).inverse() * along(up_from_frame, i, stamp);
  }
  throw InputError("frames '" + frame + "' and '" + target + "' are not connected on /tf_static and /tf ('" + frame +
                   "' leads up to '" + up_from_frame.back() + "', '" + target + "' to '" + up_from_target.back() + "')");
}

}  // namespace locd::server
