#include "locd/emoi_markov/local_elevation_map.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

#include "locd/sdk/errors.hpp"

namespace locd::emoi {
namespace {
constexpr float kUnknown = std::numeric_limits<float>::quiet_NaN();

Eigen::Vector2i cell_of(const Eigen::Vector2d& position, double resolution) {
  return {static_cast<int>(std::floor(position.x() / resolution)),
          static_cast<int>(std::floor(position.y() / resolution))};
}
}  // namespace

Eigen::Isometry3d tilting_laser_pose(double x_tilt, double z_tilt, double x_laser, double z_laser,
                                     double tilt_angle) {
  // Eq. 1: laser -> tilt frame (no rotation, offset to the sensing point).
  Eigen::Isometry3d tilt_T_laser = Eigen::Isometry3d::Identity();
  tilt_T_laser.translation() = Eigen::Vector3d(x_laser, 0.0, z_laser);
  // Eq. 2: tilt -> robot frame, rotation about y by the tilt angle, offset to the tilt axis.
  Eigen::Isometry3d robot_T_tilt = Eigen::Isometry3d::Identity();
  const double c = std::cos(tilt_angle), s = std::sin(tilt_angle);
  robot_T_tilt.linear() << c, 0, s, 0, 1, 0, -s, 0, c;
  robot_T_tilt.translation() = Eigen::Vector3d(x_tilt, 0.0, z_tilt);
  return robot_T_tilt * tilt_T_laser;  // eq. 3
}

Eigen::Matrix3d rpy_rotation(double yaw, double pitch, double roll) {
  const double cf = std::cos(yaw), sf = std::sin(yaw), ct = std::cos(pitch), st = std::sin(pitch);
  const double cp = std::cos(roll), sp = std::sin(roll);
  Eigen::Matrix3d R;  // eq. 4
  R << cf * ct, cf * st * sp - sf * cp, cf * st * cp + sf * sp,  //
      sf * ct, sf * st * sp + cf * cp, sf * st * cp - cf * sp,   //
      -st, ct * sp, ct * cp;
  return R;
}

LocalElevationMap::LocalElevationMap(const LocalMapConfig& config) : config_(config) {
  if (!(config.resolution > 0) || !(config.size_m > 4 * config.resolution)) {
    throw ConfigError("local map size " + std::to_string(config.size_m) + " m at resolution " +
                      std::to_string(config.resolution) + " m; allowed: at least 4 cells");
  }
  cells_ = static_cast<int>(std::lround(config.size_m / config.resolution));
  elevation_ = cv::Mat_<float>(cells_, cells_, kUnknown);
  seen_at_ = cv::Mat_<float>(cells_, cells_, 0.0f);
}

void LocalElevationMap::follow(const Eigen::Vector2d& position) {
  const Eigen::Vector2i cell = cell_of(position, config_.resolution);
  const Eigen::Vector2i wanted = cell - Eigen::Vector2i(cells_ / 2, cells_ / 2);
  if (!anchored_) {
    origin_cell_ = wanted;
    anchored_ = true;
    return;
  }
  const Eigen::Vector2i local = cell - origin_cell_;
  const int low = cells_ / 4, high = cells_ - cells_ / 4;
  if (local.x() >= low && local.x() < high && local.y() >= low && local.y() < high) return;
  const Eigen::Vector2i shift = wanted - origin_cell_;  // new (0, 0) in old grid cells
  cv::Mat_<float> elevation(cells_, cells_, kUnknown), seen(cells_, cells_, 0.0f);
  const int col_begin = std::max(0, shift.x()), col_end = std::min(cells_, cells_ + shift.x());
  const int row_begin = std::max(0, shift.y()), row_end = std::min(cells_, cells_ + shift.y());
  if (col_begin < col_end && row_begin < row_end) {
    const cv::Rect from(col_begin, row_begin, col_end - col_begin, row_end - row_begin);
    const cv::Rect to(col_begin - shift.x(), row_begin - shift.y(), from.width, from.height);
    elevation_(from).copyTo(elevation(to));
    seen_at_(from).copyTo(seen(to));
  }
  elevation_ = elevation;
  seen_at_ = seen;
  origin_cell_ = wanted;
}

bool LocalElevationMap::insert_point(const Eigen::Vector3d& point, double travelled_m) {
  const Eigen::Vector2i local = cell_of(point.head<2>(), config_.resolution) - origin_cell_;
  if (local.x() < 0 || local.y() < 0 || local.x() >= cells_ || local.y() >= cells_) return false;
  float& cell = elevation_(local.y(), local.x());
  float& seen = seen_at_(local.y(), local.x());
  const bool outdated = travelled_m - seen > std::min(config_.memory_distance_m, config_.refresh_distance_m);
  const float z = static_cast<float>(point.z());
  if (!std::isfinite(cell) || outdated || z > cell) cell = z;  // eq. 5: keep the highest return
  seen = static_cast<float>(travelled_m);
  return true;
}

InsertStatistics LocalElevationMap::insert_scan(const LaserScan& scan, const Eigen::Isometry3d& T_odom_base,
                                                double travelled_m) {
  InsertStatistics stats;
  const Eigen::Isometry3d T_odom_laser = T_odom_base * scan.sensor_pose;
  for (size_t i = 0; i < scan.ranges.size(); ++i) {
    const double d = scan.ranges[i];
    if (!scan.valid_return(i) || d < config_.min_point_range_m) {
      ++stats.invalid;
      continue;
    }
    const double alpha = scan.angle(i);
    const Eigen::Vector3d point = T_odom_laser * Eigen::Vector3d(d * std::cos(alpha), d * std::sin(alpha), 0.0);
    if (!point.allFinite()) {
      ++stats.invalid;
    } else if (insert_point(point, travelled_m)) {
      ++stats.inserted;
    } else {
      ++stats.out_of_grid;
    }
  }
  return stats;
}

InsertStatistics LocalElevationMap::insert_cloud(const PointCloud& cloud, const Eigen::Isometry3d& T_odom_base,
                                                 double travelled_m) {
  InsertStatistics stats;
  const Eigen::Isometry3d T_odom_sensor = T_odom_base * cloud.sensor_pose;
  for (const auto& p : cloud.points) {
    if (!p.allFinite() || p.norm() < config_.min_point_range_m) {
      ++stats.invalid;
      continue;
    }
    const Eigen::Vector3d point = T_odom_sensor * p.cast<double>();
    if (insert_point(point, travelled_m)) {
      ++stats.inserted;
    } else {
      ++stats.out_of_grid;
    }
  }
  return stats;
}

cv::Mat_<float> LocalElevationMap::observed(double travelled_m) const {
  cv::Mat_<float> out = elevation_.clone();
  if (config_.memory_distance_m >= 1e8) return out;
  for (int r = 0; r < cells_; ++r) {
    float* e = out.ptr<float>(r);
    const float* s = seen_at_.ptr<float>(r);
    for (int c = 0; c < cells_; ++c) {
      if (travelled_m - s[c] > config_.memory_distance_m) e[c] = kUnknown;
    }
  }
  return out;
}

size_t LocalElevationMap::observed_cells(double travelled_m) const {
  const cv::Mat_<float> map = observed(travelled_m);
  size_t n = 0;
  for (int r = 0; r < cells_; ++r) {
    const float* e = map.ptr<float>(r);
    for (int c = 0; c < cells_; ++c) n += std::isfinite(e[c]) ? 1 : 0;
  }
  return n;
}

void LocalElevationMap::record_pose(double travelled_m, const Eigen::Vector2d& odom_position) {
  if (!trajectory_.empty() && travelled_m < trajectory_.back().first) trajectory_.clear();  // travel restarted
  if (!trajectory_.empty() && travelled_m == trajectory_.back().first) {
    trajectory_.back().second = odom_position;
  } else {
    trajectory_.emplace_back(travelled_m, odom_position);
  }
  // Keep what the remembered cells need (one record older than the memory), at most 1e5 records.
  const double oldest = travelled_m - std::min(config_.memory_distance_m, 1e7);
  while (trajectory_.size() > 2 && (trajectory_[1].first <= oldest || trajectory_.size() > 100'000)) {
    trajectory_.pop_front();
  }
}

Eigen::Vector2d LocalElevationMap::recorded_position(double travelled_m) const {
  if (trajectory_.empty()) return Eigen::Vector2d::Zero();
  if (travelled_m <= trajectory_.front().first) return trajectory_.front().second;
  if (travelled_m >= trajectory_.back().first) return trajectory_.back().second;
  const auto after = std::lower_bound(trajectory_.begin(), trajectory_.end(), travelled_m,
                                      [](const auto& record, double t) { return record.first < t; });
  const auto before = std::prev(after);
  const double span = after->first - before->first;
  const double f = span > 0 ? (travelled_m - before->first) / span : 1.0;
  return before->second + f * (after->second - before->second);
}

double LocalElevationMap::patch_reach_m(const Eigen::Vector2d& position, double cell_m, int radius_cells,
                                        double max_correction) const {
  double reach = 0.0;  // how far back the remembered cells were written from
  if (max_correction > 0.0) {
    for (const auto& record : trajectory_) reach = std::max(reach, (record.second - position).norm());
  }
  return (radius_cells + 1) * cell_m * std::sqrt(2.0) + max_correction * reach + config_.resolution;  // the patch's corners
}

LocalElevationMap::PatchCells LocalElevationMap::patch_cells(const Eigen::Vector2d& position, double reach_m,
                                                             double travelled_m) const {
  PatchCells out;
  const double res = config_.resolution;
  const Eigen::Vector2i low = cell_of(position - Eigen::Vector2d::Constant(reach_m), res) - origin_cell_;
  const Eigen::Vector2i high = cell_of(position + Eigen::Vector2d::Constant(reach_m), res) - origin_cell_;
  // Cells written at the same travel share their displacement: looked up once per distinct mark.
  float cached_seen = std::numeric_limits<float>::quiet_NaN();
  Eigen::Vector2f cached = Eigen::Vector2f::Zero();
  for (int r = std::max(0, low.y()); r <= std::min(cells_ - 1, high.y()); ++r) {
    const float* e = elevation_.ptr<float>(r);
    const float* s = seen_at_.ptr<float>(r);
    for (int c = std::max(0, low.x()); c <= std::min(cells_ - 1, high.x()); ++c) {
      if (!std::isfinite(e[c]) || travelled_m - s[c] > config_.memory_distance_m) continue;
      const Eigen::Vector2d relative = (origin_cell_ + Eigen::Vector2i(c, r)).cast<double>() * res +
                                       Eigen::Vector2d::Constant(res / 2) - position;
      if (relative.squaredNorm() > reach_m * reach_m) continue;
      if (!(s[c] == cached_seen)) {
        cached_seen = s[c];
        cached = trajectory_.empty() ? Eigen::Vector2f::Zero()
                                     : Eigen::Vector2f((recorded_position(s[c]) - position).cast<float>());
      }
      out.relative.push_back(relative.cast<float>());
      out.since_written.push_back(cached);
      out.elevation.push_back(e[c]);
    }
  }
  return out;
}

cv::Mat_<float> LocalElevationMap::bin_patch(const PatchCells& cells, double heading_offset, double cell_m,
                                             int radius_cells, double centre_elevation,
                                             const Eigen::Matrix2d& distortion) {
  return PatchBinner(cells, heading_offset, cell_m, radius_cells, centre_elevation).patch(distortion);
}

PatchBinner::PatchBinner(const LocalElevationMap::PatchCells& cells, double heading_offset, double cell_m,
                         int radius_cells, double centre_elevation, double max_correction)
    : rotation_(Eigen::Rotation2Dd(heading_offset).toRotationMatrix()),
      cell_m_(cell_m),
      radius_cells_(radius_cells),
      centre_elevation_(centre_elevation),
      max_correction_(max_correction) {
  const Eigen::Matrix2f to_map = (rotation_ / cell_m).cast<float>();
  const size_t n = cells.elevation.size();
  in_cells_.reserve(n);
  elevation_.reserve(n);
  for (size_t k = 0; k < n; ++k) {
    const Eigen::Vector2f in_cells = to_map * cells.relative[k];
    // |(B - I) R v| <= |B - I|_F |v|: a cell farther out than that from the patch never lands in it.
    const double reach = radius_cells + 1.0 + max_correction * cells.since_written[k].norm() / cell_m;
    if (std::abs(in_cells.x()) > reach || std::abs(in_cells.y()) > reach) continue;
    if (runs_.empty() || !(cells.since_written[k] == runs_.back().since_written)) {
      runs_.push_back({in_cells_.size(), in_cells_.size(), cells.since_written[k]});
    }
    in_cells_.push_back(in_cells);
    elevation_.push_back(cells.elevation[k]);
    runs_.back().end = in_cells_.size();
  }
}

cv::Mat_<float> PatchBinner::patch(const Eigen::Matrix2d& distortion) const {
  if ((distortion - Eigen::Matrix2d::Identity()).norm() > max_correction_ + 1e-9) {
    throw InputError("patch asked for a distortion beyond the binner's max_correction");
  }
  const int side = 2 * radius_cells_ + 1;
  std::vector<double> sum(static_cast<size_t>(side) * side, 0.0);
  std::vector<int> count(static_cast<size_t>(side) * side, 0);
  // A cell written at travel t moves by (distortion - I) (P_odom(t) - position), in the map frame.
  const Eigen::Matrix2f moved = (rotation_ * (distortion - Eigen::Matrix2d::Identity()) / cell_m_).cast<float>();
  for (const Run& run : runs_) {
    const Eigen::Vector2f shift = moved * run.since_written;
    for (size_t k = run.begin; k < run.end; ++k) {
      const Eigen::Vector2f in_cells = in_cells_[k] + shift;
      const int j = cvRound(in_cells.x()) + radius_cells_;
      const int i = cvRound(in_cells.y()) + radius_cells_;
      if (static_cast<unsigned>(i) >= static_cast<unsigned>(side) || static_cast<unsigned>(j) >= static_cast<unsigned>(side)) {
        continue;
      }
      const size_t index = static_cast<size_t>(i) * side + j;
      sum[index] += elevation_[k];
      count[index] += 1;
    }
  }
  cv::Mat_<float> patch(side, side, kUnknown);
  for (int i = 0; i < side; ++i) {
    for (int j = 0; j < side; ++j) {
      const size_t index = static_cast<size_t>(i) * side + j;
      if (count[index] > 0) patch(i, j) = static_cast<float>(sum[index] / count[index] - centre_elevation_);
    }
  }
  return patch;
}

cv::Mat_<float> LocalElevationMap::robot_patch(const Eigen::Vector2d& position, double heading_offset, double cell_m,
                                               int radius_cells, double centre_elevation, double travelled_m,
                                               const Eigen::Matrix2d& distortion) const {
  const double correction = (distortion - Eigen::Matrix2d::Identity()).norm();
  const PatchCells cells =
      patch_cells(position, patch_reach_m(position, cell_m, radius_cells, correction), travelled_m);
  return bin_patch(cells, heading_offset, cell_m, radius_cells, centre_elevation, distortion);
}

GridGeometry LocalElevationMap::geometry() const {
  GridGeometry g;
  g.resolution = config_.resolution;
  g.origin = origin_cell_.cast<double>() * config_.resolution;
  g.width = cells_;
  g.height = cells_;
  return g;
}

std::vector<PointEmoi> LocalElevationMap::emoi(const Eigen::Vector2d& position, double centre_elevation,
                                               const std::vector<double>& radii_m, double travelled_m) const {
  const cv::Mat_<float> map = observed(travelled_m);
  const Eigen::Vector2i local = cell_of(position, config_.resolution) - origin_cell_;
  std::vector<PointEmoi> out;
  for (double radius : radii_m) {
    out.push_back(emoi_at(map, config_.resolution, local.y(), local.x(), centre_elevation, radius));
  }
  return out;
}

}  // namespace locd::emoi
