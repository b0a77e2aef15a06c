#include "locd/sim_grid_mcl/grid_worlds.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <random>
#include <stdexcept>

#include "locd/sim/world.hpp"

namespace locd::sim::grid {

namespace {


// Obstacles drawn into a grid; finish() frees what is reachable from a seed.
class Canvas {
 public:
  Canvas(const Eigen::Vector2d& min, const Eigen::Vector2d& max, double resolution) {
    g_.resolution = resolution;
    g_.origin = min;
    g_.width = static_cast<int>(std::ceil((max.x() - min.x()) / resolution));
    g_.height = static_cast<int>(std::ceil((max.y() - min.y()) / resolution));
    occupied_.assign(g_.size(), 0);
  }

  void mark(int row, int col) {
    if (g_.contains(row, col)) occupied_[static_cast<size_t>(row) * g_.width + col] = 1;
  }

  // Every cell the segment passes through, 4-connected (no diagonal gap a ray could slip through).
  void segment(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const double length = (b - a).norm();
    const int steps = std::max(1, static_cast<int>(std::ceil(length / (g_.resolution / 8.0))));
    int last_row = 0, last_col = 0;
    bool first = true;
    for (int i = 0; i <= steps; ++i) {
      const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(i) / steps);
      const int col = static_cast<int>(std::floor((p.x() - g_.origin.x()) / g_.resolution));
      const int row = static_cast<int>(std::floor((p.y() - g_.origin.y()) / g_.resolution));
      if (!first && row != last_row && col != last_col) mark(last_row, col);
      mark(row, col);
      last_row = row;
      last_col = col;
      first = false;
    }
  }

  // The cells a rectangle [x0, x1] x [y0, y1] overlaps.
  void rectangle(double x0, double y0, double x1, double y1) {
    const int c0 = static_cast<int>(std::floor((x0 - g_.origin.x()) / g_.resolution));
    const int c1 = static_cast<int>(std::ceil((x1 - g_.origin.x()) / g_.resolution)) - 1;
    const int r0 = static_cast<int>(std::floor((y0 - g_.origin.y()) / g_.resolution));
    const int r1 = static_cast<int>(std::ceil((y1 - g_.origin.y()) / g_.resolution)) - 1;
    for (int r = r0; r <= r1; ++r)
      for (int c = c0; c <= c1; ++c) mark(r, c);
  }

  OccupancyMap finish(const Eigen::Vector2d& free_seed) const {
    std::vector<int8_t> cells(g_.size(), OccupancyMap::kUnknown);
    for (size_t i = 0; i < cells.size(); ++i) {
      if (occupied_[i]) cells[i] = OccupancyMap::kOccupied;
    }
    int row = 0, col = 0;
    if (!g_.index_of(free_seed, row, col) || occupied_[static_cast<size_t>(row) * g_.width + col]) {
      throw std::invalid_argument("grid world: the free seed lies outside the grid or in an obstacle");
    }
    std::deque<size_t> open{static_cast<size_t>(row) * g_.width + col};
    cells[open.front()] = OccupancyMap::kFree;
    while (!open.empty()) {
      const size_t i = open.front();
      open.pop_front();
      const int r = static_cast<int>(i / g_.width), c = static_cast<int>(i % g_.width);
      const int next[4][2] = {{r + 1, c}, {r - 1, c}, {r, c + 1}, {r, c - 1}};
      for (const auto& n : next) {
        if (!g_.contains(n[0], n[1])) continue;
        const size_t j = static_cast<size_t>(n[0]) * g_.width + n[1];
        if (cells[j] != OccupancyMap::kUnknown) continue;
        cells[j] = OccupancyMap::kFree;
        open.push_back(j);
      }
    }
    return OccupancyMap(g_, std::move(cells));
  }

 private:
  GridGeometry g_;
  std::vector<uint8_t> occupied_;
};

}  // namespace

OccupancyMap rasterize_walls(const FeatureMap2D& map, double resolution, double margin, const Eigen::Vector2d& free_seed) {
  const SegmentWorld walls = SegmentWorld::from_feature_map(map);
  Eigen::AlignedBox2d box;
  for (const Segment& s : walls.segments()) {
    box.extend(s.a);
    box.extend(s.b);
  }
  // The origin on a whole number of cells, so wall coordinates fall on cell boundaries alike.
  const Eigen::Vector2d min = ((box.min().array() - margin) / resolution).floor() * resolution;
  const Eigen::Vector2d max = ((box.max().array() + margin) / resolution).ceil() * resolution;
  Canvas canvas(min, max, resolution);
  for (const Segment& s : walls.segments()) canvas.segment(s.a, s.b);
  return canvas.finish(free_seed);
}

std::vector<Eigen::Vector2d> warehouse_route() {
  return {{8, 15}, {45, 15}, {45, 42}, {52.5, 48}, {52.5, 96}, {25.1, 96}, {25.1, 48}, {8, 48}};
}

OccupancyMap make_warehouse(const WarehouseConfig& config) {
  Canvas c(Eigen::Vector2d(-3, -3), Eigen::Vector2d(103, 103), config.resolution);
  // Outer walls, 0.3 m, with eight loading docks (3.5 m wide, 2 m deep bays) on the south wall at
  // irregular spacing and a wide door on the west wall.
  c.rectangle(-0.3, 99.7, 100.3, 100.0);
  c.rectangle(99.7, -0.3, 100.0, 100.3);
  c.rectangle(-0.3, 30.0, 0.0, 100.3);
  c.rectangle(-0.3, -0.3, 0.0, 26.0);  // the west door: y 26-30
  c.rectangle(-2.3, 26.0, 0.0, 26.3);
  c.rectangle(-2.3, 29.7, 0.0, 30.0);
  c.rectangle(-2.6, 26.0, -2.3, 30.0);
  const double docks[] = {6.0, 13.0, 20.0, 27.0, 41.0, 48.0, 55.0, 69.0};
  double x = -0.3;
  for (double d : docks) {
    c.rectangle(x, -0.3, d, 0.0);  // wall up to the bay
    c.rectangle(d - 0.3, -2.0, d, 0.0);
    c.rectangle(d + 3.5, -2.0, d + 3.8, 0.0);
    c.rectangle(d, -2.3, d + 3.8, -2.0);
    x = d + 3.5;
  }
  c.rectangle(x, -0.3, 100.3, 0.0);

  // Rack zone A (north-west): 8 double racks 2.4 m deep running north-south, 3 m aisles; each
  // split by a cross aisle of 3 m at an irregular height, and of irregular length.
  for (int k = 0; k < 8; ++k) {
    const double x0 = 5.0 + 5.4 * k, x1 = x0 + 2.4;
    const double top = 93.0 - (k % 3) * 1.5;
    const double gap = 60.0 + 4.0 * ((k * 3) % 7);
    c.rectangle(x0, 52.0, x1, gap - 1.5);
    c.rectangle(x0, gap + 1.5, x1, top);
  }
  // Rack zone B (east): 4 double racks 2.4 m deep running east-west, with cross aisles at
  // irregular places.
  for (int k = 0; k < 4; ++k) {
    const double y0 = 55.0 + 5.4 * k, y1 = y0 + 2.4;
    const double gap = 66.0 + 6.0 * ((k * 5) % 4);
    c.rectangle(57.0 + 1.0 * (k % 2), y0, gap - 1.5, y1);
    c.rectangle(gap + 1.5, y0, 95.0 - 2.0 * (k % 3), y1);
  }
  // Offices in the north-east corner: 20 x 18 m, three rooms along a hallway, doors 1 m.
  c.rectangle(80.0, 82.0, 80.15, 100.0);
  c.rectangle(80.0, 82.0, 84.0, 82.15);  // front wall with the entrance at x 84-86
  c.rectangle(86.0, 82.0, 100.0, 82.15);
  c.rectangle(80.0, 88.0, 82.0, 88.15);  // hallway wall, doors at 82-83 and 90-91
  c.rectangle(83.0, 88.0, 90.0, 88.15);
  c.rectangle(91.0, 88.0, 100.0, 88.15);
  for (double wall : {86.0, 93.0}) c.rectangle(wall, 88.0, wall + 0.15, 100.0);
  // A fenced cage (mesh seen as a thin wall) with an opening, and pillars on a 12 m grid in the
  // staging area (south) and the open north-east area.
  c.rectangle(62.0, 10.0, 76.0, 10.1);
  c.rectangle(62.0, 24.0, 76.0, 24.1);
  c.rectangle(76.0, 10.0, 76.1, 24.1);
  c.rectangle(62.0, 10.0, 62.1, 14.0);
  c.rectangle(62.0, 18.0, 62.1, 24.1);
  for (double px = 12.0; px < 99.0; px += 12.0) {
    for (double py = 12.0; py < 44.0; py += 12.0) {
      if (px > 60.0 && px < 78.0 && py > 8.0 && py < 26.0) continue;  // inside the cage
      c.rectangle(px - 0.25, py - 0.25, px + 0.25, py + 0.25);
    }
  }
  for (double px = 60.0; px < 79.0; px += 9.0) c.rectangle(px - 0.25, 86.75, px + 0.25, 87.25);
  // Pallet stacks (1.2 x 1.0 m) in the staging area and the north-east, away from the route.
  std::mt19937_64 rng(config.seed);
  std::uniform_real_distribution<double> sx(3.0, 97.0), sy(3.0, 43.0), nx(58.0, 78.0), ny(78.0, 97.0);
  const std::vector<Eigen::Vector2d> route = warehouse_route();
  const auto near_route = [&](const Eigen::Vector2d& p) {
    for (size_t i = 0; i < route.size(); ++i) {
      const Eigen::Vector2d a = route[i], b = route[(i + 1) % route.size()];
      const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      if ((a + t * (b - a) - p).norm() < 3.0) return true;
    }
    return false;
  };
  int placed = 0;
  for (int attempt = 0; attempt < 400 && placed < 40; ++attempt) {
    const bool north = attempt % 4 == 3;
    const Eigen::Vector2d p = north ? Eigen::Vector2d(nx(rng), ny(rng)) : Eigen::Vector2d(sx(rng), sy(rng));
    if (near_route(p) || (p.x() > 60.0 && p.x() < 78.0 && p.y() < 27.0)) continue;
    const bool turned = (attempt / 2) % 2 == 0;
    const double hx = turned ? 0.6 : 0.5, hy = turned ? 0.5 : 0.6;
    c.rectangle(p.x() - hx, p.y() - hy, p.x() + hx, p.y() + hy);
    ++placed;
  }
  return c.finish(route.front());
}

}  // namespace locd::sim::grid
