#include "locd/sim/reference_trajectory.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

#include "locd/sdk/text.hpp"
#include "locd/sim/evaluator.hpp"

namespace locd::sim {
namespace {

constexpr const char* kFields[] = {"t", "x", "y", "z", "qx", "qy", "qz", "qw"};

double yaw_of(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

}  // namespace

ReferenceTrajectory ReferenceTrajectory::read_tum(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw ReferenceError("reference " + file + ": cannot be opened");
  ReferenceTrajectory out;
  out.file_ = file;
  std::string line;
  size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::string where = "reference " + file + " line " + std::to_string(number);
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    long double value[8];
    std::string token;
    for (int i = 0; i < 8; ++i) {
      if (!(fields >> token)) {
        throw ReferenceError(where + ": field " + kFields[i] + " is missing; TUM lines are 't x y z qx qy qz qw'");
      }
      size_t used = 0;
      try {
        value[i] = std::stold(token, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != token.size() || !std::isfinite(value[i])) {
        throw ReferenceError(where + ": field " + kFields[i] + " = '" + escaped(token, 64) + "' is not a finite number");
      }
    }
    if (fields >> token) {
      throw ReferenceError(where + ": more than 8 fields ('" + escaped(token, 64) + "'); TUM lines are 't x y z qx qy qz qw'");
    }
    if (value[0] < 0 || value[0] > 9.2e9L) {
      throw ReferenceError(where + ": field t = " + escaped(line.substr(first, 32)) + " is not a time in seconds in [0, 9.2e9]");
    }
    const int64_t stamp = static_cast<int64_t>(std::llround(value[0] * 1e9L));
    Eigen::Quaterniond q(static_cast<double>(value[7]), static_cast<double>(value[4]), static_cast<double>(value[5]),
                         static_cast<double>(value[6]));
    if (q.norm() < 1e-6) throw ReferenceError(where + ": fields qx qy qz qw are a zero quaternion");
    q.normalize();
    if (!out.poses_.empty() && stamp <= out.poses_.rbegin()->first) {
      throw ReferenceError(where + ": field t goes backwards or repeats (the previous pose has t = " +
                           std::to_string(static_cast<double>(out.poses_.rbegin()->first) * 1e-9) + " s)");
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q.toRotationMatrix();
    T.translation() = Eigen::Vector3d(static_cast<double>(value[1]), static_cast<double>(value[2]), static_cast<double>(value[3]));
    out.poses_.emplace_hint(out.poses_.end(), stamp, T);
  }
  if (in.bad()) throw ReferenceError("reference " + file + ": read error after line " + std::to_string(number));
  if (out.poses_.empty()) throw ReferenceError("reference " + file + ": no pose (" + std::to_string(number) + " lines)");
  return out;
}

std::optional<Eigen::Isometry3d> ReferenceTrajectory::at(int64_t stamp_ns) const {
  auto after = poses_.lower_bound(stamp_ns);
  if (after == poses_.end()) return std::nullopt;
  if (after->first == stamp_ns) return after->second;
  if (after == poses_.begin()) return std::nullopt;
  const auto before = std::prev(after);
  const double span = static_cast<double>(after->first - before->first);
  if (span * 1e-9 > kMaxGapS) return std::nullopt;
  const double f = static_cast<double>(stamp_ns - before->first) / span;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(before->second.linear()).slerp(f, Eigen::Quaterniond(after->second.linear())).toRotationMatrix();
  T.translation() = (1.0 - f) * before->second.translation() + f * after->second.translation();
  return T;
}

AbsolutePoseError absolute_pose_error(const std::map<int64_t, Eigen::Isometry3d>& poses, const ReferenceTrajectory& reference) {
  AbsolutePoseError e;
  std::vector<double> errors;
  double sum = 0, sum_squares = 0, heading_squares = 0;
  size_t over = 0;
  std::vector<double> relative;
  std::optional<std::pair<Eigen::Isometry3d, Eigen::Isometry3d>> previous;  // estimate, reference
  for (const auto& [stamp, pose] : poses) {
    const auto truth = reference.at(stamp);
    if (!truth) {
      ++e.not_covered;
      previous.reset();
      continue;
    }
    if (previous) {
      const Eigen::Isometry3d error =
          (previous->second.inverse() * *truth).inverse() * (previous->first.inverse() * pose);
      relative.push_back(error.translation().norm());
    }
    previous = std::make_pair(pose, *truth);
    const double d = (pose.translation() - truth->translation()).norm();
    const double heading = std::abs(std::remainder(yaw_of(pose) - yaw_of(*truth), 2.0 * M_PI)) * 180.0 / M_PI;
    errors.push_back(d);
    sum += d;
    sum_squares += d * d;
    heading_squares += heading * heading;
    e.max_m = std::max(e.max_m, d);
    e.heading_max_deg = std::max(e.heading_max_deg, heading);
    if (d > 0.5) ++over;
  }
  e.poses = errors.size();
  if (e.poses == 0) return e;
  const double n = static_cast<double>(e.poses);
  e.rmse_m = std::sqrt(sum_squares / n);
  e.mean_m = sum / n;
  e.median_m = percentile(errors, 50.0);
  e.heading_rmse_deg = std::sqrt(heading_squares / n);
  e.share_over_half_metre = static_cast<double>(over) / n;
  e.rpe_pairs = relative.size();
  if (!relative.empty()) {
    double rsum = 0, rsquares = 0;
    for (double r : relative) {
      rsum += r;
      rsquares += r * r;
      e.rpe_max_m = std::max(e.rpe_max_m, r);
    }
    e.rpe_rmse_m = std::sqrt(rsquares / static_cast<double>(relative.size()));
    e.rpe_mean_m = rsum / static_cast<double>(relative.size());
    e.rpe_median_m = percentile(relative, 50.0);
  }
  return e;
}

}  // namespace locd::sim
