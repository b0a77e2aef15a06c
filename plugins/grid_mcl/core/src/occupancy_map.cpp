#include "locd/grid_mcl/occupancy_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace locd::grid_mcl {

std::optional<double> cast(const OccupancyMap& map, const Eigen::Vector2d& origin, double angle, double max_range,
                           bool stop_at_unknown) {
  const GridGeometry& g = map.geometry();
  const double inv = 1.0 / g.resolution;
  // In cell units, the grid spans [0, width) x [0, height).
  const Eigen::Vector2d start = (origin - g.origin) * inv;
  const Eigen::Vector2d dir(std::cos(angle), std::sin(angle));
  const double t_max = max_range * inv;
  // Clip the ray to the grid box (slabs).
  double t_enter = 0.0, t_exit = t_max;
  for (int axis = 0; axis < 2; ++axis) {
    const double size = axis == 0 ? g.width : g.height;
    if (std::abs(dir[axis]) < 1e-12) {
      if (start[axis] < 0.0 || start[axis] >= size) return stop_at_unknown ? std::optional<double>(0.0) : std::nullopt;
      continue;
    }
    double t0 = (0.0 - start[axis]) / dir[axis], t1 = (size - start[axis]) / dir[axis];
    if (t0 > t1) std::swap(t0, t1);
    t_enter = std::max(t_enter, t0);
    t_exit = std::min(t_exit, t1);
  }
  const bool inside = start.x() >= 0.0 && start.y() >= 0.0 && start.x() < g.width && start.y() < g.height;
  if (!inside && stop_at_unknown) return 0.0;
  if (t_enter > t_exit) return std::nullopt;
  const Eigen::Vector2d p = start + t_enter * dir;
  int col = std::clamp(static_cast<int>(std::floor(p.x())), 0, g.width - 1);
  int row = std::clamp(static_cast<int>(std::floor(p.y())), 0, g.height - 1);
  const int step_col = dir.x() > 0 ? 1 : -1, step_row = dir.y() > 0 ? 1 : -1;
  const double delta_col = std::abs(dir.x()) < 1e-12 ? std::numeric_limits<double>::infinity() : 1.0 / std::abs(dir.x());
  const double delta_row = std::abs(dir.y()) < 1e-12 ? std::numeric_limits<double>::infinity() : 1.0 / std::abs(dir.y());
  double next_col = std::abs(dir.x()) < 1e-12 ? std::numeric_limits<double>::infinity()
                                              : ((dir.x() > 0 ? col + 1 : col) - start.x()) / dir.x();
  double next_row = std::abs(dir.y()) < 1e-12 ? std::numeric_limits<double>::infinity()
                                              : ((dir.y() > 0 ? row + 1 : row) - start.y()) / dir.y();
  double t = t_enter;
  while (t <= t_max) {
    const int8_t cell = map.at(row, col);
    if (cell == OccupancyMap::kOccupied || (stop_at_unknown && cell != OccupancyMap::kFree)) {
      // The surface an occupied cell stands for passes through its centre: the range is to the
      // point of the ray nearest the centre, within the stretch the ray spends in the cell.
      const double centre = (Eigen::Vector2d(col + 0.5, row + 0.5) - start).dot(dir);
      const double hit = std::clamp(centre, t, std::min(next_col, next_row));
      return hit <= t_max ? std::optional<double>(hit * g.resolution) : std::nullopt;
    }
    if (next_col < next_row) {
      t = next_col;
      next_col += delta_col;
      col += step_col;
      if (col < 0 || col >= g.width) break;
    } else {
      t = next_row;
      next_row += delta_row;
      row += step_row;
      if (row < 0 || row >= g.height) break;
    }
  }
  if (stop_at_unknown && t <= t_max) return t * g.resolution;  // left the map
  return std::nullopt;
}

}  // namespace locd::grid_mcl
