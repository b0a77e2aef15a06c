// A reference trajectory (the "ground truth" of a real log) in TUM format, what evo and most
// benchmarks read: one pose per line, `t x y z qx qy qz qw` (t in seconds, the quaternion of the
// body in the reference frame, Hamilton, w last), '#' comments and blank lines skipped. And the
// absolute pose error of a localizer's poses against it, in evo's terms (APE on the translation,
// no alignment: both are in the map frame).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace locd::sim {

class ReferenceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ReferenceTrajectory {
 public:
  // A gap between two reference poses wider than this is not interpolated across.
  static constexpr double kMaxGapS = 1.0;

  // Throws ReferenceError naming the file, the line and the field: not 8 numbers, a non-finite
  // value, a zero quaternion, a stamp not after the previous line's, no pose at all.
  static ReferenceTrajectory read_tum(const std::string& file);

  // The pose at `stamp_ns`: positions interpolated linearly, rotations by slerp between the two
  // poses around it; nullopt outside [first, last] or across a gap wider than kMaxGapS.
  std::optional<Eigen::Isometry3d> at(int64_t stamp_ns) const;

  int64_t first_ns() const { return poses_.begin()->first; }
  int64_t last_ns() const { return poses_.rbegin()->first; }
  size_t size() const { return poses_.size(); }
  const std::string& file() const { return file_; }

 private:
  std::string file_;
  std::map<int64_t, Eigen::Isometry3d> poses_;
};

// APE of poses (stamp -> pose) against a reference: translation error statistics as evo's
// `evo_ape` prints them, the heading error, the share of poses more than 0.5 m off.
struct AbsolutePoseError {
  size_t poses = 0;        // compared
  size_t not_covered = 0;  // outside the reference (or in one of its gaps): not compared
  double rmse_m = 0, mean_m = 0, median_m = 0, max_m = 0;
  double heading_rmse_deg = 0, heading_max_deg = 0;
  double share_over_half_metre = 0;  // 0..1
  // RPE as evo_rpe's default (delta 1 pose, translation part): between consecutive compared
  // poses i, i+1, the translation of (Q_i^-1 Q_i+1)^-1 (P_i^-1 P_i+1), P estimates, Q reference.
  size_t rpe_pairs = 0;
  double rpe_rmse_m = 0, rpe_mean_m = 0, rpe_median_m = 0, rpe_max_m = 0;
};
AbsolutePoseError absolute_pose_error(const std::map<int64_t, Eigen::Isometry3d>& poses, const ReferenceTrajectory& reference);

}  // namespace locd::sim
