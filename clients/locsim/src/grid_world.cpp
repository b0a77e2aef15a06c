#include "locd/sim/grid_world.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <limits>

namespace locd::sim {

namespace {
// Direction components below this are axis-parallel; coordinates within this of a grid line lie
// on it; boundary crossings this close are one corner (cell units: 5e-11 m at 0.05 m cells).
constexpr double kParallel = 1e-12, kOnLine = 1e-9;

bool on_line(double coordinate) { return std::abs(coordinate - std::round(coordinate)) < kOnLine; }
}  // namespace

GridWorld::GridWorld(std::shared_ptr<const OccupancyMap> map) : map_(std::move(map)) {}

bool GridWorld::solid_at(int row, int col) const {
  return map_->geometry().contains(row, col) && solid(map_->at(row, col));
}

std::optional<double> GridWorld::cast(const Eigen::Vector2d& origin, double angle, double max_range) const {
  const GridGeometry& g = map_->geometry();
  if (g.width <= 0 || g.height <= 0) return std::nullopt;
  // In cell units the grid spans [0, width] x [0, height].
  const Eigen::Vector2d start = (origin - g.origin) / g.resolution;
  Eigen::Vector2d dir(std::cos(angle), std::sin(angle));
  for (int axis = 0; axis < 2; ++axis) {
    if (std::abs(dir[axis]) < kParallel) dir[axis] = 0.0;
  }
  const double t_max = max_range / g.resolution;
  // Clip the ray to the grid's box (slabs): it is inside over [t_enter, t_exit].
  double t_enter = 0.0, t_exit = t_max;
  for (int axis = 0; axis < 2; ++axis) {
    const double size = axis == 0 ? g.width : g.height;
    if (dir[axis] == 0.0) {
      if (start[axis] < -kOnLine || start[axis] > size + kOnLine) return std::nullopt;
      continue;
    }
    double t0 = -start[axis] / dir[axis], t1 = (size - start[axis]) / dir[axis];
    if (t0 > t1) std::swap(t0, t1);
    t_enter = std::max(t_enter, t0);
    t_exit = std::min(t_exit, t1);
  }
  if (t_enter > t_exit) return std::nullopt;

  const Eigen::Vector2d p = start + t_enter * dir;
  int col = std::clamp(static_cast<int>(std::floor(p.x())), 0, g.width - 1);
  int row = std::clamp(static_cast<int>(std::floor(p.y())), 0, g.height - 1);
  // A ray along a grid line touches the cells on both sides: line_col - 1 and line_col.
  const bool along_column_line = dir.x() == 0.0 && on_line(start.x());
  const bool along_row_line = dir.y() == 0.0 && on_line(start.y());
  const int line_col = static_cast<int>(std::round(start.x())), line_row = static_cast<int>(std::round(start.y()));
  const auto touches_solid = [&](int r, int c) {
    if (along_column_line) return solid_at(r, line_col - 1) || solid_at(r, line_col);
    if (along_row_line) return solid_at(line_row - 1, c) || solid_at(line_row, c);
    return solid_at(r, c);
  };

  const double inf = std::numeric_limits<double>::infinity();
  const int step_col = dir.x() > 0 ? 1 : -1, step_row = dir.y() > 0 ? 1 : -1;
  const double delta_col = dir.x() != 0.0 ? 1.0 / std::abs(dir.x()) : inf;
  const double delta_row = dir.y() != 0.0 ? 1.0 / std::abs(dir.y()) : inf;
  double next_col = dir.x() != 0.0 ? ((dir.x() > 0 ? col + 1 : col) - start.x()) / dir.x() : inf;
  double next_row = dir.y() != 0.0 ? ((dir.y() > 0 ? row + 1 : row) - start.y()) / dir.y() : inf;
  double t = t_enter;
  for (;;) {
    if (touches_solid(row, col)) return t * g.resolution;
    const bool corner = std::abs(next_col - next_row) <= kOnLine * std::max(1.0, std::min(next_col, next_row));
    t = std::min(next_col, next_row);
    if (t > t_max) return std::nullopt;
    if (corner) {
      // Through a corner: the two cells beside it are touched too.
      if (solid_at(row, col + step_col) || solid_at(row + step_row, col)) return t * g.resolution;
      col += step_col;
      row += step_row;
      next_col += delta_col;
      next_row += delta_row;
    } else if (next_col < next_row) {
      col += step_col;
      next_col += delta_col;
    } else {
      row += step_row;
      next_row += delta_row;
    }
    const bool inside_cols = along_column_line ? true : (col >= 0 && col < g.width);
    const bool inside_rows = along_row_line ? true : (row >= 0 && row < g.height);
    if (!inside_cols || !inside_rows) return std::nullopt;
  }
}

bool is_occupancy_map_yaml(const std::filesystem::path& yaml_file) {
  try {
    const YAML::Node node = YAML::LoadFile(yaml_file.string());
    return node.IsMap() && node["image"].IsDefined();
  } catch (const YAML::Exception&) {
    return false;  // the feature-map loader reports what is wrong
  }
}

}  // namespace locd::sim
