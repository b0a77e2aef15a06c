// The transforms a ROS 2 robot publishes on /tf_static and /tf, for a sensor frame's pose in its
// base frame at a message's stamp, as tf2's lookupTransform(target, source, stamp) gives it: the
// chain from each frame up to their common ancestor, static links at any time, dynamic links
// interpolated between the two samples around the stamp and never extrapolated (tf2 refuses
// that too). Bounded: kMaxFrames frames (a new frame beyond them is ignored), each dynamic link's
// last kSamplesPerLink samples. Thread-safe: the tf readers add, the sensor readers look up.
#pragma once

#include <map>
#include <mutex>
#include <string>

#include "locd/dds/ros2_convert.hpp"
#include "locd/sdk/pose_history.hpp"

namespace locd::server {

class TransformBuffer : public dds::ros2::FrameSource {
 public:
  static constexpr size_t kMaxFrames = 256;
  static constexpr size_t kSamplesPerLink = 256;  // 2.5 s of a 100 Hz link, 5 s of a 50 Hz one
  static constexpr int kMaxChain = 64;  // links from a frame to its root; a longer chain is a loop

  // `transform` from /tf_static (is_static) or /tf: a later one for the same child replaces its
  // parent and, if static, its pose; a dynamic one adds a sample (a zero stamp is refused there).
  void add(const dds::ros2::StampedTransform& transform, bool is_static);
  Eigen::Isometry3d pose_in(const std::string& target, const std::string& frame, int64_t stamp_ns) const override;

 private:
  struct Link {
    std::string parent;
    bool is_static = true;
    Eigen::Isometry3d parent_from_child = Eigen::Isometry3d::Identity();  // static
    PoseHistory samples{kSamplesPerLink};                                  // dynamic
  };
  // The pose of `frame` in `ancestor`, composed along the chain; `chain` is frame, its parent, ...
  Eigen::Isometry3d along(const std::vector<std::string>& chain, size_t to, int64_t stamp_ns) const;
  std::vector<std::string> chain_of(const std::string& frame) const;

  mutable std::mutex mutex_;
  std::map<std::string, Link> links_;  // by child frame
};

}  // namespace locd::server
