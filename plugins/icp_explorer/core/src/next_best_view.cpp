#include "locd/icp_explorer/next_best_view.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>

namespace locd::icp_explorer {

NextBestViewPlanner::NextBestViewPlanner(const ExplorationSettings& settings) : settings_(settings) {}

double NextBestViewPlanner::reliability(double r) const {
  const double overlap = 1.0 - std::exp(-r / settings_.overlap_distance);
  const double range = r <= settings_.reliable_distance
                           ? 1.0
                           : std::exp(-(r - settings_.reliable_distance) / settings_.reliable_falloff);
  return overlap * range;
}

double NextBestViewPlanner::direction_term(const Eigen::Vector2d& robot, const Eigen::Vector2d& candidate,
                                           const std::vector<Eigen::Vector2d>& scan_positions) const {
  const Eigen::Vector2d to_candidate = candidate - robot;
  if (to_candidate.norm() < 1e-9) return 1.0;
  const Eigen::Vector2d u = to_candidate.normalized();
  double worst = 0.0;
  for (const Eigen::Vector2d& s : scan_positions) {
    const Eigen::Vector2d to_scan = s - robot;
    const double d = to_scan.norm();
    if (d < 1e-6 || d > settings_.memory_radius) continue;
    worst = std::max(worst, u.dot(to_scan / d));
  }
  return 1.0 - settings_.direction_penalty * worst;
}

std::vector<float> NextBestViewPlanner::movable(const LayeredHexahedralMap& map, const Eigen::Vector2d& robot,
                                                std::vector<float>* path_length) const {
  const int columns = map.columns(), rows = map.rows();
  const size_t cells = static_cast<size_t>(columns) * rows;
  const double cell = map.settings().cell_size;
  std::vector<CellState> column(cells);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      column[static_cast<size_t>(r) * columns + c] = map.column_state(c, r, settings_.robot_height);
  // A column is blocked when the returns of an occupied column come within the robot radius of
  // its centre (clearance to the surface itself, not to the cube holding it); a scan position
  // also needs its whole footprint known, with no unknown column within the radius.
  std::vector<char> blocked(cells, 0), unclear(cells, 0);
  const int reach = static_cast<int>(std::ceil(settings_.robot_radius / cell + 0.5));
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c) {
      const CellState s = column[static_cast<size_t>(r) * columns + c];
      if (s == CellState::kEmpty) continue;
      Eigen::AlignedBox2d obstacle;
      if (s == CellState::kOccupied) {
        obstacle = map.obstacle_extent(c, r, settings_.robot_height);
        const Eigen::Vector2d half = Eigen::Vector2d::Constant(0.5 * cell);
        if (obstacle.isEmpty()) obstacle = Eigen::AlignedBox2d(map.column_centre(c, r) - half, map.column_centre(c, r) + half);
      }
      for (int dr = -reach; dr <= reach; ++dr)
        for (int dc = -reach; dc <= reach; ++dc) {
          const int rr = r + dr, cc = c + dc;
          if (rr < 0 || cc < 0 || rr >= rows || cc >= columns) continue;
          const size_t j = static_cast<size_t>(rr) * columns + cc;
          if (s == CellState::kUnknown) {
            if (std::hypot(dr, dc) * cell <= settings_.robot_radius + 0.5 * cell) unclear[j] = 1;
          } else if (obstacle.exteriorDistance(map.column_centre(cc, rr)) <= settings_.robot_radius) {
            blocked[j] = unclear[j] = 1;
          }
        }
    }
  int c0 = 0, r0 = 0;
  std::vector<float> m(cells, 0.0f);
  std::vector<float> length(cells, std::numeric_limits<float>::infinity());
  if (!map.column_of(robot, c0, r0)) {
    if (path_length) *path_length = length;
    return m;
  }
  // Dijkstra over passable columns; through_unknown = false allows empty columns only.
  auto flood = [&](bool through_unknown) {
    std::vector<float> dist(cells, std::numeric_limits<float>::infinity());
    using Entry = std::pair<float, size_t>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
    const size_t start = static_cast<size_t>(r0) * columns + c0;
    dist[start] = 0.0f;
    open.emplace(0.0f, start);
    while (!open.empty()) {
      const auto [d, i] = open.top();
      open.pop();
      if (d > dist[i]) continue;
      const int r = static_cast<int>(i / columns), c = static_cast<int>(i % columns);
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc) {
          if (!dr && !dc) continue;
          const int rr = r + dr, cc = c + dc;
          if (rr < 0 || cc < 0 || rr >= rows || cc >= columns) continue;
          const size_t j = static_cast<size_t>(rr) * columns + cc;
          // Inside the inflation the robot may only move on to leave it (it may stand there
          // after the map around it filled in).
          if (blocked[j] && !blocked[i]) continue;
          const CellState s = column[j];
          if (s == CellState::kOccupied || (!through_unknown && s != CellState::kEmpty)) continue;
          const float nd = d + static_cast<float>(cell * ((dr && dc) ? M_SQRT2 : 1.0));
          if (nd < dist[j]) {
            dist[j] = nd;
            open.emplace(nd, j);
          }
        }
    }
    return dist;
  };
  const std::vector<float> over_empty = flood(false);
  const std::vector<float> over_unknown = flood(true);
  for (size_t i = 0; i < cells; ++i) {
    if (column[i] != CellState::kEmpty || unclear[i]) continue;
    if (std::isfinite(over_empty[i])) {
      m[i] = 1.0f;
      length[i] = over_empty[i];
    } else if (std::isfinite(over_unknown[i])) {
      m[i] = static_cast<float>(settings_.possibly_movable_weight);
      length[i] = over_unknown[i];
    }
  }
  if (path_length) *path_length = std::move(length);
  return m;
}

std::pair<double, double> NextBestViewPlanner::exploratory_and_resumable(const LayeredHexahedralMap& map, int column,
                                                                         int row) const {
  const int columns = map.columns(), rows = map.rows(), layers = map.layers();
  const double cell = map.settings().cell_size;
  const Eigen::Vector2d origin = map.column_centre(column, row);
  std::vector<char> conflicted(static_cast<size_t>(columns) * rows, 2);  // 2 = not computed
  std::vector<char> counted(static_cast<size_t>(columns) * rows * layers, 0);
  double exploratory = 0.0, resumable = 0.0;
  const int steps = static_cast<int>(std::ceil(settings_.max_range / (0.5 * cell)));
  for (int layer = 0; layer < layers; ++layer) {
    const double dz = map.layer_centre_z(layer) - settings_.sensor_height;
    for (int k = 0; k < settings_.rays; ++k) {
      const double angle = 2.0 * M_PI * k / settings_.rays;
      const Eigen::Vector2d u(std::cos(angle), std::sin(angle));
      int last_c = column, last_r = row;
      for (int s = 1; s <= steps; ++s) {
        const double horizontal = s * 0.5 * cell;
        int c = 0, r = 0;
        if (!map.column_of(origin + horizontal * u, c, r)) break;
        if (c == last_c && r == last_r) continue;
        last_c = c;
        last_r = r;
        const CellState state = map.state(layer, c, r);
        if (state == CellState::kOccupied) break;
        if (state != CellState::kUnknown) continue;
        const double elevation = std::atan2(dz, horizontal);
        if (elevation < settings_.elevation_min || elevation > settings_.elevation_max) continue;
        const size_t flat = (static_cast<size_t>(layer) * rows + r) * columns + c;
        if (counted[flat]) continue;
        counted[flat] = 1;
        const double gain = (1.0 - map.probability(layer, c, r)) * map.detection_from(std::hypot(horizontal, dz));
        exploratory += gain;
        char& is_conflicted = conflicted[static_cast<size_t>(r) * columns + c];
        if (is_conflicted == 2) is_conflicted = map.conflicted(c, r) ? 1 : 0;
        if (is_conflicted) resumable += gain;
      }
    }
  }
  return {exploratory, resumable};
}

ExplorationDecision NextBestViewPlanner::decide(const LayeredHexahedralMap& map, const Eigen::Vector2d& robot,
                                                const std::vector<Eigen::Vector2d>& scan_positions,
                                                ExplorationTerms* terms) const {
  std::vector<float> path_length;
  const std::vector<float> m = movable(map, robot, &path_length);
  const int columns = map.columns(), rows = map.rows();
  auto make_grid = [&](const char* name) {
    GridLayer g;
    g.layer = name;
    g.resolution = map.settings().cell_size;
    g.origin = map.settings().origin;
    g.width = columns;
    g.height = rows;
    g.cells.assign(static_cast<size_t>(columns) * rows, std::numeric_limits<float>::quiet_NaN());
    return g;
  };
  if (terms) {
    terms->movable = make_grid("movable");
    terms->exploratory = make_grid("exploratory");
    terms->resumable = make_grid("resumable");
    terms->score = make_grid("exploration_score");
    for (size_t i = 0; i < m.size(); ++i) terms->movable.cells[i] = m[i];
  }
  ExplorationDecision best;
  best.score = -1.0;
  const int stride = std::max(1, settings_.candidate_stride);
  for (int r = 0; r < rows; r += stride)
    for (int c = 0; c < columns; c += stride) {
      const size_t i = static_cast<size_t>(r) * columns + c;
      if (m[i] <= 0.0f) continue;
      ++best.candidates;
      const auto [e, rs] = exploratory_and_resumable(map, c, r);
      const double S = m[i] * (e + settings_.beta * rs);  // eq. 2
      const Eigen::Vector2d xy = map.column_centre(c, r);
      const double R = reliability(path_length[i]);
      const double T = direction_term(robot, xy, scan_positions);
      const double P = R * S * T;  // eq. 4, alpha = 1
      best.potential = std::max(best.potential, S);
      if (terms) {
        terms->exploratory.cells[i] = static_cast<float>(e);
        terms->resumable.cells[i] = static_cast<float>(rs);
        terms->score.cells[i] = static_cast<float>(P);
      }
      if (P > best.score) {
        best.score = P;
        best.goal = xy;
        best.movable = m[i];
        best.exploratory = e;
        best.resumable = rs;
        best.reliability = R;
        best.direction = T;
        best.path_length = path_length[i];
      }
    }
  best.done = best.potential < settings_.done_threshold;
  if (best.score < 0.0) best.score = 0.0;
  best.heading = (best.goal - robot).norm() > 1e-9 ? std::atan2(best.goal.y() - robot.y(), best.goal.x() - robot.x()) : 0.0;
  return best;
}

}  // namespace locd::icp_explorer
