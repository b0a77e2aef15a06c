#include "locd/grid_mcl/laser_models.hpp"

#include <algorithm>
#include <cmath>

#include "locd/sdk/errors.hpp"

namespace locd::grid_mcl {

size_t PreparedScan::hits() const { return static_cast<size_t>(std::count(hit.begin(), hit.end(), uint8_t{1})); }

PreparedScan prepare_scan(const LaserScan& scan, const LaserModelConfig& config) {
  PreparedScan s;
  const size_t n = scan.ranges.size();
  s.beams_in_scan = n;
  s.z_max = config.max_range > 0.0 ? std::min<double>(scan.range_max, config.max_range) : scan.range_max;
  const double z_min = config.min_range > 0.0 ? std::max<double>(scan.range_min, config.min_range) : scan.range_min;
  s.sensor_position = scan.sensor_pose.translation().head<2>();
  if (n == 0) return s;
  const Eigen::Matrix3d rotation = scan.sensor_pose.linear();
  // AMCL: every step-th beam, step = (n - 1) / (max_beams - 1) in integers, at least 1.
  size_t step = config.max_beams > 1 ? (n - 1) / static_cast<size_t>(config.max_beams - 1) : n;
  step = std::max<size_t>(step, 1);
  for (size_t i = 0; i < n; i += step) {
    const double a = scan.angle(i);
    const Eigen::Vector2d direction = (rotation * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0)).head<2>();
    const double horizontal = direction.norm();
    if (horizontal < 1e-6) continue;  // a beam pointing straight up or down
    // REP 117: NaN, zero and too-close readings say nothing (skipped, as AMCL skips NaN); a
    // no-return or max-range reading is a max reading (z_max), which only the beam model uses.
    const RangeReading reading = scan.reading(i);
    const double r = scan.ranges[i];
    if (reading == RangeReading::kInvalid || reading == RangeReading::kTooClose) continue;
    if (reading == RangeReading::kHit && r <= z_min) continue;
    const double range = reading == RangeReading::kNoReturn ? s.z_max : std::min(r * horizontal, s.z_max);
    s.bearing.push_back(std::atan2(direction.y(), direction.x()));
    s.range.push_back(range);
    const bool hit = range < s.z_max;
    s.hit.push_back(hit ? 1 : 0);
    s.end.push_back(s.sensor_position + (hit ? range : 0.0) * direction / horizontal);
  }
  return s;
}

LaserModel::LaserModel(std::shared_ptr<const SharedMap> map, const LaserModelConfig& config)
    : map_(std::move(map)), config_(config), type_(config.type), sigma_hit_(config.sigma_hit) {
  if (!map_) throw ConfigError("grid_mcl: the laser model needs a map");
}

void LaserModel::set_search(bool search, double sigma_hit) {
  const LaserModelType type = search ? LaserModelType::kLikelihoodField : config_.type;
  if (type == type_ && sigma_hit == sigma_hit_) return;
  type_ = type;
  sigma_hit_ = sigma_hit;
  table_z_max_ = -1.0;  // rebuild the table
}

double LaserModel::hit_density(double distance, bool unknown, double z_max, double sigma_hit) const {
  const double d = std::min(distance, config_.likelihood_max_dist);
  const double known = config_.z_hit * std::exp(-d * d / (2.0 * sigma_hit * sigma_hit)) + config_.z_rand / z_max;
  if (!unknown) return known;
  const double u = config_.unknown_occupancy;
  return u * (config_.z_hit + config_.z_rand / z_max) + (1.0 - u) * known;
}

void LaserModel::prepare(const PreparedScan& scan) {
  if (type_ == LaserModelType::kBeam) return;
  // Beam ends in cell units, hits only.
  const double inv = 1.0 / map_->map.geometry().resolution;
  end_x_.clear();
  end_y_.clear();
  for (size_t k = 0; k < scan.end.size(); ++k) {
    if (!scan.hit[k]) continue;
    end_x_.push_back(static_cast<float>(scan.end[k].x() * inv));
    end_y_.push_back(static_cast<float>(scan.end[k].y() * inv));
  }
  if (scan.z_max == table_z_max_) return;
  // One entry per field code (distance units, and the unknown bit): the fast path indexes it
  // with the code as it is. hit_density saturates at laser_likelihood_max_dist.
  const double step = map_->field.step();
  table_.resize(DistanceField::kCodes);
  for (size_t i = 0; i < table_.size(); ++i) {
    const double d = static_cast<double>(i & DistanceField::kSaturated) * step;
    const bool unknown = (i & DistanceField::kUnknownBit) != 0;
    const double pz = hit_density(d, unknown, scan.z_max, sigma_hit_);
    table_[i].term = static_cast<float>(log_domain() ? std::log(pz) : pz * pz * pz);
    table_[i].measure = static_cast<float>(hit_density(d, unknown, scan.z_max, config_.sigma_hit));
  }
  table_z_max_ = scan.z_max;
}

void LaserModel::factors(const std::vector<PoseParticle>& particles, size_t begin, size_t end, const PreparedScan& scan,
                         double* factor, double* mean_pz) const {
  const GridGeometry& g = map_->map.geometry();
  if (type_ == LaserModelType::kBeam) {
    for (size_t m = begin; m < end; ++m) factor[m - begin] = factor_direct(particles[m].pose, scan, &mean_pz[m - begin]);
    return;
  }
  // Per particle the cell of a beam end X (cell units, float: exact to 1e-3 cells on 8000-cell
  // maps) is (int)(X + 1) - 1: floor(X) for X > -1, negative (outside) below 0.
  const double inv = 1.0 / g.resolution;
  const float* ex = end_x_.data();
  const float* ey = end_y_.data();
  const size_t hits = end_x_.size();
  const uint16_t* field = map_->field.cells().data();
  const FieldEntry* table = table_.data();
  const uint32_t outside = DistanceField::kUnknownBit | DistanceField::kSaturated;  // beyond the map
  const unsigned width = static_cast<unsigned>(g.width), height = static_cast<unsigned>(g.height);
  const bool log = log_domain();
  const double per_hit = hits > 0 ? 1.0 / static_cast<double>(hits) : 0.0;
  for (size_t m = begin; m < end; ++m) {
    const Pose2& p = particles[m].pose;
    const double px = (p.x - g.origin.x()) * inv, py = (p.y - g.origin.y()) * inv;
    float sum = 0.0f, measured = 0.0f;
    if (!(std::abs(px) < 1e6 && std::abs(py) < 1e6)) {  // far off (or not finite): every beam outside
      sum = table[outside].term * static_cast<float>(hits);
      measured = table[outside].measure * static_cast<float>(hits);
    } else {
      const float x0 = static_cast<float>(px) + 1.0f, y0 = static_cast<float>(py) + 1.0f;
      const float c = static_cast<float>(std::cos(p.theta)), s = static_cast<float>(std::sin(p.theta));
      // Four partial sums: the additions of consecutive beams do not wait for each other.
      float sums[4] = {0.0f, 0.0f, 0.0f, 0.0f}, measures[4] = {0.0f, 0.0f, 0.0f, 0.0f};
      const auto beam = [&](size_t k, int lane) {
        const unsigned col = static_cast<unsigned>(static_cast<int>(x0 + c * ex[k] - s * ey[k]) - 1);
        const unsigned row = static_cast<unsigned>(static_cast<int>(y0 + s * ex[k] + c * ey[k]) - 1);
        const uint32_t code = col < width && row < height ? field[static_cast<size_t>(row) * width + col] : outside;
        const FieldEntry entry = table[code];
        sums[lane] += entry.term;
        measures[lane] += entry.measure;
      };
      size_t k = 0;
      for (; k + 4 <= hits; k += 4) {
        beam(k, 0);
        beam(k + 1, 1);
        beam(k + 2, 2);
        beam(k + 3, 3);
      }
      for (; k < hits; ++k) beam(k, 0);
      sum = (sums[0] + sums[1]) + (sums[2] + sums[3]);
      measured = (measures[0] + measures[1]) + (measures[2] + measures[3]);
    }
    factor[m - begin] = log ? static_cast<double>(sum) : 1.0 + static_cast<double>(sum);
    mean_pz[m - begin] = static_cast<double>(measured) * per_hit;
  }
}

double LaserModel::beam_pz(double measured, double expected, double z_max) const {
  const double z = measured - expected;
  double pz = config_.z_hit * std::exp(-z * z / (2.0 * config_.sigma_hit * config_.sigma_hit));
  if (z < 0.0) pz += config_.z_short * config_.lambda_short * std::exp(-config_.lambda_short * measured);
  if (measured >= z_max) pz += config_.z_max;
  if (measured < z_max) pz += config_.z_rand / z_max;
  return pz;
}

double LaserModel::factor_direct(const Pose2& pose, const PreparedScan& scan, double* mean_pz) const {
  const OccupancyMap& map = map_->map;
  const GridGeometry& g = map.geometry();
  const Eigen::Vector2d sensor = pose.transform(scan.sensor_position);
  double sum = 0.0, measured = 0.0;
  size_t counted = 0;
  for (size_t k = 0; k < scan.range.size(); ++k) {
    if (type_ == LaserModelType::kBeam) {
      const auto expected = cast(map, sensor, pose.theta + scan.bearing[k], scan.z_max, true);
      const double pz = beam_pz(scan.range[k], expected.value_or(scan.z_max), scan.z_max);
      sum += pz * pz * pz;
      measured += pz;
      ++counted;
      continue;
    }
    if (!scan.hit[k]) continue;
    int row = 0, col = 0;
    const bool inside = g.index_of(pose.transform(scan.end[k]), row, col);
    const double d = inside ? map_->field.distance(row, col) : config_.likelihood_max_dist;
    const bool unknown = !inside || map.at(row, col) == OccupancyMap::kUnknown;
    const double pz = hit_density(d, unknown, scan.z_max, sigma_hit_);
    sum += log_domain() ? std::log(pz) : pz * pz * pz;
    measured += hit_density(d, unknown, scan.z_max, config_.sigma_hit);
    ++counted;
  }
  if (mean_pz) *mean_pz = counted > 0 ? measured / static_cast<double>(counted) : 0.0;
  return log_domain() ? sum : 1.0 + sum;
}

double LaserModel::fit(const Pose2& pose, const PreparedScan& scan, double distance, bool known_only,
                       double* counted) const {
  const GridGeometry& g = map_->map.geometry();
  const double inv = 1.0 / g.resolution;
  const Eigen::Vector2d start = (pose.transform(scan.sensor_position) - g.origin) * inv;
  size_t all = 0, hits = 0, close = 0;
  for (size_t k = 0; k < scan.end.size(); ++k) {
    if (!scan.hit[k]) continue;
    ++all;
    int row = 0, col = 0;
    const bool inside = g.index_of(pose.transform(scan.end[k]), row, col);
    const bool fits = inside && map_->field.distance(row, col) <= distance;
    if (known_only && !fits && (!inside || map_->map.at(row, col) == OccupancyMap::kUnknown) &&
        !meets_wall(start, pose.theta + scan.bearing[k], scan.range[k] * inv)) {
      continue;
    }
    ++hits;
    if (fits) ++close;
  }
  if (counted) *counted = all > 0 ? static_cast<double>(hits) / static_cast<double>(all) : 0.0;
  return hits > 0 ? static_cast<double>(close) / static_cast<double>(hits) : 0.0;
}

bool LaserModel::meets_wall(const Eigen::Vector2d& start, double angle, double end) const {
  // The ray skips free space over the distance field (sphere tracing): from a point in a cell
  // whose centre lies D cells from the nearest occupied cell's centre, no occupied cell meets the
  // ray within D - sqrt(2) cells. Within a cell or so of a wall it goes on cell by cell
  // (OccupancyMap::cast), so the answer is cast's over the whole ray.
  const OccupancyMap& map = map_->map;
  const GridGeometry& g = map.geometry();
  const DistanceField& field = map_->field;
  constexpr double kUnit = 1.0 / DistanceField::kSubdivision;  // cells per field unit
  const Eigen::Vector2d dir(std::cos(angle), std::sin(angle));
  for (double t = 0.0; t < end;) {
    const Eigen::Vector2d p = start + t * dir;
    const bool inside = p.x() >= 0.0 && p.y() >= 0.0 && p.x() < g.width && p.y() < g.height;
    // Off the grid cast clips the ray to it (it may come back in).
    const double clear = inside ? field.at(static_cast<int>(p.y()), static_cast<int>(p.x())) * kUnit - M_SQRT2 : 0.0;
    if (clear < 1.0) return cast(map, g.origin + p * g.resolution, angle, (end - t) * g.resolution).has_value();
    t += clear;
  }
  return false;
}

double LaserModel::see_through(const Pose2& pose, const PreparedScan& scan, double margin, double fraction) const {
  const GridGeometry& g = map_->map.geometry();
  const double inv = 1.0 / g.resolution;
  const Eigen::Vector2d start = (pose.transform(scan.sensor_position) - g.origin) * inv;
  size_t hits = 0, through = 0;
  for (size_t k = 0; k < scan.range.size(); ++k) {
    if (!scan.hit[k]) continue;
    ++hits;
    const double end = ((1.0 - fraction) * scan.range[k] - margin) * inv;  // cells
    through += meets_wall(start, pose.theta + scan.bearing[k], end);
  }
  return hits > 0 ? static_cast<double>(through) / static_cast<double>(hits) : 0.0;
}

}  // namespace locd::grid_mcl
