// The nearest-frontier baseline the exploration benchmark compares next best view with: Yamauchi's
// frontier exploration on icp_explorer's layered map collapsed to 2D, with the planner's own
// traversability, so that both strategies move by the same rules.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "locd/icp_explorer/layered_hexahedral_map.hpp"
#include "locd/icp_explorer/next_best_view.hpp"

namespace locd::icp_explorer {

// Nearest-frontier exploration (Yamauchi 1997) on the same map collapsed to 2D (a column is
// occupied / empty / unknown below the robot's height): a frontier is an empty column next to an
// unknown one; the goal is the nearest reachable scan position (the planner's movable columns:
// footprint known empty) with a frontier within its footprint plus one cell, at least
// min_distance away and at least min_distance from every earlier scan stop (a frontier that one
// scan did not resolve is not tried again); done when there is none.
inline std::optional<Eigen::Vector2d> nearest_frontier(const LayeredHexahedralMap& map,
                                                       const NextBestViewPlanner& planner,
                                                       const Eigen::Vector2d& robot,
                                                       const std::vector<Eigen::Vector2d>& scan_stops,
                                                       double min_distance) {
  
  std::vector<float> length;
  const std::vector<float> m = planner.movable(map, robot, &length);
  const double height = planner.settings().robot_height;
  const int columns = map.columns(), rows = map.rows();
  // Frontier columns: empty, with an unknown 4-neighbour (the edge of the known free space).
  std::vector<CellState> state(static_cast<size_t>(columns) * rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c) state[static_cast<size_t>(r) * columns + c] = map.column_state(c, r, height);
  auto at = [&](int c, int r) {
    return (c < 0 || r < 0 || c >= columns || r >= rows) ? CellState::kOccupied : state[static_cast<size_t>(r) * columns + c];
  };
  std::vector<char> frontier(state.size(), 0);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      frontier[static_cast<size_t>(r) * columns + c] =
          at(c, r) == CellState::kEmpty && (at(c + 1, r) == CellState::kUnknown || at(c - 1, r) == CellState::kUnknown ||
                                            at(c, r + 1) == CellState::kUnknown || at(c, r - 1) == CellState::kUnknown);
  // A scan position serves a frontier within its footprint plus one cell.
  const int reach = static_cast<int>(std::ceil(planner.settings().robot_radius / map.settings().cell_size)) + 1;
  std::optional<Eigen::Vector2d> best;
  double best_length = std::numeric_limits<double>::infinity();
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c) {
      const size_t i = static_cast<size_t>(r) * columns + c;
      if (m[i] < 1.0f || length[i] < min_distance || length[i] >= best_length) continue;
      const Eigen::Vector2d xy = map.column_centre(c, r);
      bool visited = false;
      for (const auto& stop : scan_stops) visited |= (stop - xy).norm() < min_distance;
      if (visited) continue;
      bool serves = false;
      for (int dr = -reach; dr <= reach && !serves; ++dr)
        for (int dc = -reach; dc <= reach && !serves; ++dc) {
          const int rr = r + dr, cc = c + dc;
          serves = rr >= 0 && cc >= 0 && rr < rows && cc < columns && frontier[static_cast<size_t>(rr) * columns + cc];
        }
      if (!serves) continue;
      best_length = length[i];
      best = xy;
    }
  return best;
}

}  // namespace locd::icp_explorer
