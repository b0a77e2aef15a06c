// A regular 2D grid of cells with its geometry, grid_map style: row-major, row 0 at origin.y,
// cell (row, col) spans origin + [col, col+1) x [row, row+1) times resolution.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "locd/sdk/types.hpp"

namespace locd {

struct GridGeometry {
  double resolution = 1.0;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  int width = 0;
  int height = 0;

  size_t size() const { return static_cast<size_t>(width) * static_cast<size_t>(height); }
  bool contains(int row, int col) const { return row >= 0 && col >= 0 && row < height && col < width; }
  // False (index untouched) when the position is outside the grid.
  bool index_of(const Eigen::Vector2d& position, int& row, int& col) const;
  Eigen::Vector2d center_of(int row, int col) const;
};

template <typename T>
class Grid {
 public:
  Grid() = default;
  Grid(GridGeometry geometry, T fill) : geometry_(geometry), cells_(geometry.size(), fill) {}
  const GridGeometry& geometry() const { return geometry_; }
  int width() const { return geometry_.width; }
  int height() const { return geometry_.height; }
  T& at(int row, int col) { return cells_[static_cast<size_t>(row) * geometry_.width + col]; }
  const T& at(int row, int col) const { return cells_[static_cast<size_t>(row) * geometry_.width + col]; }
  std::vector<T>& cells() { return cells_; }
  const std::vector<T>& cells() const { return cells_; }

 private:
  GridGeometry geometry_;
  std::vector<T> cells_;
};

// Packs a float grid as a named output layer for the diagnostics/grid topic.
GridLayer to_layer(const Grid<float>& grid, const std::string& layer);

}  // namespace locd
