#include "locd/sim/world.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace locd::sim {

namespace {
double cross(const Eigen::Vector2d& u, const Eigen::Vector2d& v) { return u.x() * v.y() - u.y() * v.x(); }
}  // namespace

std::optional<double> ray_segment_distance(const Eigen::Vector2d& origin, const Eigen::Vector2d& direction,
                                           const Segment& segment) {
  // origin + t d = a + u (b - a)  =>  t = (a - o) x e / (d x e),  u = (a - o) x d / (d x e)
  const Eigen::Vector2d e = segment.b - segment.a;
  const double denominator = cross(direction, e);
  if (std::abs(denominator) < 1e-12 * e.norm()) return std::nullopt;
  const Eigen::Vector2d w = segment.a - origin;
  const double t = cross(w, e) / denominator;
  const double u = cross(w, direction) / denominator;
  if (t < 0.0 || u < 0.0 || u > 1.0) return std::nullopt;
  return t;
}

SegmentWorld::SegmentWorld(std::vector<Segment> segments, double cell_size_m)
    : segments_(std::move(segments)), cell_size_(cell_size_m) {
  if (!(cell_size_m > 0.0)) throw std::invalid_argument("SegmentWorld: cell size must be positive");
  for (const auto& s : segments_) {
    bounds_.extend(s.a);
    bounds_.extend(s.b);
  }
  if (segments_.empty()) return;
  bounds_.min() -= Eigen::Vector2d::Constant(cell_size_);
  bounds_.max() += Eigen::Vector2d::Constant(cell_size_);
  columns_ = static_cast<int>(std::ceil(bounds_.sizes().x() / cell_size_));
  rows_ = static_cast<int>(std::ceil(bounds_.sizes().y() / cell_size_));
  cells_.assign(static_cast<size_t>(columns_) * rows_, {});
  for (size_t i = 0; i < segments_.size(); ++i) {
    const auto& s = segments_[i];
    const Eigen::Vector2d lo = (s.a.cwiseMin(s.b) - bounds_.min()) / cell_size_;
    const Eigen::Vector2d hi = (s.a.cwiseMax(s.b) - bounds_.min()) / cell_size_;
    for (int r = static_cast<int>(lo.y()); r <= static_cast<int>(hi.y()) && r < rows_; ++r) {
      for (int c = static_cast<int>(lo.x()); c <= static_cast<int>(hi.x()) && c < columns_; ++c) {
        cells_[static_cast<size_t>(r) * columns_ + c].push_back(static_cast<int>(i));
      }
    }
  }
}

SegmentWorld SegmentWorld::from_feature_map(const FeatureMap2D& map, double cell_size_m) {
  std::vector<Segment> segments;
  segments.reserve(map.lines.size());
  for (const auto& line : map.lines) segments.push_back({line.a, line.b});
  return SegmentWorld(std::move(segments), cell_size_m);
}

std::optional<double> SegmentWorld::cast_brute_force(const Eigen::Vector2d& origin, double angle,
                                                     double max_range) const {
  const Eigen::Vector2d direction(std::cos(angle), std::sin(angle));
  double best = std::numeric_limits<double>::infinity();
  for (const auto& s : segments_) {
    const auto t = ray_segment_distance(origin, direction, s);
    if (t && *t < best) best = *t;
  }
  if (best > max_range) return std::nullopt;
  return best;
}

std::optional<double> SegmentWorld::cast(const Eigen::Vector2d& origin, double angle, double max_range) const {
  if (segments_.empty()) return std::nullopt;
  if (!bounds_.contains(origin)) return cast_brute_force(origin, angle, max_range);
  const Eigen::Vector2d direction(std::cos(angle), std::sin(angle));
  const Eigen::Vector2d p = (origin - bounds_.min()) / cell_size_;
  int column = std::min(static_cast<int>(p.x()), columns_ - 1);
  int row = std::min(static_cast<int>(p.y()), rows_ - 1);
  const int step_column = direction.x() >= 0 ? 1 : -1;
  const int step_row = direction.y() >= 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  // Ray length (in metres) to the next column / row boundary, and per cell crossed.
  const double delta_column = direction.x() != 0 ? cell_size_ / std::abs(direction.x()) : inf;
  const double delta_row = direction.y() != 0 ? cell_size_ / std::abs(direction.y()) : inf;
  double next_column = direction.x() != 0
      ? ((step_column > 0 ? column + 1 - p.x() : p.x() - column) * cell_size_) / std::abs(direction.x())
      : inf;
  double next_row = direction.y() != 0
      ? ((step_row > 0 ? row + 1 - p.y() : p.y() - row) * cell_size_) / std::abs(direction.y())
      : inf;
  double best = inf;
  double cell_entry = 0.0;
  while (column >= 0 && column < columns_ && row >= 0 && row < rows_ && cell_entry <= max_range) {
    for (int index : cells_[static_cast<size_t>(row) * columns_ + column]) {
      const auto t = ray_segment_distance(origin, direction, segments_[index]);
      if (t && *t < best) best = *t;
    }
    const double cell_exit = std::min(next_column, next_row);
    if (best <= cell_exit) break;  // no later cell can hold a nearer hit
    cell_entry = cell_exit;
    if (next_column < next_row) {
      column += step_column;
      next_column += delta_column;
    } else {
      row += step_row;
      next_row += delta_row;
    }
  }
  if (best > max_range) return std::nullopt;
  return best;
}

}  // namespace locd::sim
