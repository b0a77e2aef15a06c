#include "locd/emoi_markov/local_elevation_map.hpp"

#include <cmath>
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

cv::Mat_<float> LocalElevationMap::robot_patch(const Eigen::Vector2d& position, double heading_offset, double cell_m,
                                               int radius_cells, double centre_elevation, double travelled_m) const {
  const int side = 2 * radius_cells + 1;
  cv::Mat_<float> patch(side, side, kUnknown);
  const double res = config_.resolution;
  const int span = std::max(1, static_cast<int>(std::lround(cell_m / res)));
  const Eigen::Rotation2Dd map_to_odom(-heading_offset);
  for (int i = 0; i < side; ++i) {
    for (int j = 0; j < side; ++j) {
      const Eigen::Vector2d offset((j - radius_cells) * cell_m, (i - radius_cells) * cell_m);
      const Eigen::Vector2d corner = position + map_to_odom * offset - Eigen::Vector2d::Constant(cell_m / 2);
      const Eigen::Vector2i first = cell_of(corner + Eigen::Vector2d::Constant(res / 2), res) - origin_cell_;
      double sum = 0.0;
      int observed = 0;
      for (int r = std::max(0, first.y()); r < std::min(cells_, first.y() + span); ++r) {
        const float* e = elevation_.ptr<float>(r);
        const float* s = seen_at_.ptr<float>(r);
        for (int c = std::max(0, first.x()); c < std::min(cells_, first.x() + span); ++c) {
          if (!std::isfinite(e[c]) || travelled_m - s[c] > config_.memory_distance_m) continue;
          sum += e[c];
          ++observed;
        }
      }
      if (observed > 0) patch(i, j) = static_cast<float>(sum / observed - centre_elevation);
    }
  }
  return patch;
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
