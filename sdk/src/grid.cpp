#include "locd/sdk/grid.hpp"

#include <cmath>

namespace locd {

bool GridGeometry::index_of(const Eigen::Vector2d& position, int& row, int& col) const {
  const double c = std::floor((position.x() - origin.x()) / resolution);
  const double r = std::floor((position.y() - origin.y()) / resolution);
  if (!(c >= 0 && r >= 0 && c < width && r < height)) return false;
  row = static_cast<int>(r);
  col = static_cast<int>(c);
  return true;
}

Eigen::Vector2d GridGeometry::center_of(int row, int col) const {
  return origin + Eigen::Vector2d((col + 0.5) * resolution, (row + 0.5) * resolution);
}

GridLayer to_layer(const Grid<float>& grid, const std::string& layer) {
  GridLayer out;
  out.layer = layer;
  out.resolution = grid.geometry().resolution;
  out.origin = grid.geometry().origin;
  out.width = grid.width();
  out.height = grid.height();
  out.cells = grid.cells();
  return out;
}

}  // namespace locd
