#include "locd/icp_explorer/layered_hexahedral_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

namespace locd::icp_explorer {

LayeredHexahedralMap::LayeredHexahedralMap(const LayeredMapSettings& settings) : settings_(settings) {
  columns_ = std::max(1, static_cast<int>(std::ceil(settings.size.x() / settings.cell_size)));
  rows_ = std::max(1, static_cast<int>(std::ceil(settings.size.y() / settings.cell_size)));
  layers_ = std::max(1, static_cast<int>(std::floor((settings.z_max - settings.z_min) / settings.layer_height)));
  const size_t cells = static_cast<size_t>(layers_) * rows_ * columns_;
  probability_.assign(cells, 0.0f);
  seen_through_.assign(cells, 0);
  extent_.assign(cells, Eigen::AlignedBox2f());
}

bool LayeredHexahedralMap::column_of(const Eigen::Vector2d& xy, int& column, int& row) const {
  const double c = std::floor((xy.x() - settings_.origin.x()) / settings_.cell_size);
  const double r = std::floor((xy.y() - settings_.origin.y()) / settings_.cell_size);
  if (!(c >= 0 && r >= 0 && c < columns_ && r < rows_)) return false;
  column = static_cast<int>(c);
  row = static_cast<int>(r);
  return true;
}

Eigen::Vector2d LayeredHexahedralMap::column_centre(int column, int row) const {
  return settings_.origin + Eigen::Vector2d((column + 0.5) * settings_.cell_size, (row + 0.5) * settings_.cell_size);
}

double LayeredHexahedralMap::layer_centre_z(int layer) const {
  return settings_.z_min + (layer + 0.5) * settings_.layer_height;
}

double LayeredHexahedralMap::expected_returns(double kappa) const {
  const double area = settings_.cell_size * std::min(settings_.cell_size, settings_.layer_height);
  const double k = std::max(kappa, settings_.cell_size);
  return area / (k * k * settings_.azimuth_step * settings_.elevation_step);
}

double LayeredHexahedralMap::detection(double kappa, double n) const {
  const double nu = std::clamp(settings_.fill * expected_returns(kappa), 1.0, settings_.points_for_detection);
  return 1.0 - std::exp(-n / nu);
}

double LayeredHexahedralMap::detection_from(double kappa) const {
  return detection(kappa, settings_.fill * expected_returns(kappa));
}

void LayeredHexahedralMap::integrate(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& scanner) {
  const double cell = settings_.cell_size, height = settings_.layer_height;
  const Eigen::Vector3d origin(settings_.origin.x(), settings_.origin.y(), settings_.z_min);
  const Eigen::Vector3d step_size(cell, cell, height);
  const Eigen::Vector3i dims(columns_, rows_, layers_);
  auto cube_of = [&](const Eigen::Vector3d& p) -> Eigen::Vector3i {
    return ((p - origin).cwiseQuotient(step_size)).array().floor().cast<int>();
  };
  auto inside = [&](const Eigen::Vector3i& c) { return (c.array() >= 0).all() && (c.array() < dims.array()).all(); };
  auto flat = [&](const Eigen::Vector3i& c) { return index(c.z(), c.x(), c.y()); };

  // Hits per cube of this scan, with the cube's distance from the scanner.
  std::unordered_map<size_t, std::pair<double, int>> hits;
  std::vector<char> marked(probability_.size(), 0);
  std::vector<size_t> through;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3i end = cube_of(p);
    if (inside(end)) {
      auto& h = hits[flat(end)];
      h.first = (p - scanner).norm();
      ++h.second;
      extent_[flat(end)].extend(p.head<2>().cast<float>());
    }
    // Amanatides-Woo traversal from the scanner to the point; the end cube is not seen through.
    const Eigen::Vector3d d = p - scanner;
    Eigen::Vector3i c = cube_of(scanner);
    Eigen::Vector3i step;
    Eigen::Vector3d t_max, t_delta;
    for (int a = 0; a < 3; ++a) {
      if (std::abs(d[a]) < 1e-12) {
        step[a] = 0;
        t_max[a] = t_delta[a] = std::numeric_limits<double>::infinity();
        continue;
      }
      step[a] = d[a] > 0 ? 1 : -1;
      const double boundary = origin[a] + (c[a] + (d[a] > 0 ? 1 : 0)) * step_size[a];
      t_max[a] = (boundary - scanner[a]) / d[a];
      t_delta[a] = step_size[a] / std::abs(d[a]);
    }
    for (int guard = 0; guard < 4096 && c != end; ++guard) {
      if (inside(c)) {
        const size_t i = flat(c);
        if (!marked[i]) {
          marked[i] = 1;
          through.push_back(i);
        }
      }
      int a = 0;
      if (t_max[1] < t_max[a]) a = 1;
      if (t_max[2] < t_max[a]) a = 2;
      if (t_max[a] > 1.0) break;
      c[a] += step[a];
      t_max[a] += t_delta[a];
    }
  }
  for (size_t i : through)
    if (seen_through_[i] < std::numeric_limits<uint16_t>::max()) ++seen_through_[i];
  for (const auto& [i, h] : hits) {
    const double t = detection(h.first, h.second);
    probability_[i] = static_cast<float>(1.0 - (1.0 - probability_[i]) * (1.0 - t));
  }
}

CellState LayeredHexahedralMap::state(int layer, int column, int row) const {
  const size_t i = index(layer, column, row);
  if (probability_[i] >= settings_.occupied_probability) return CellState::kOccupied;
  if (seen_through_[i] > 0) return CellState::kEmpty;
  return CellState::kUnknown;
}

bool LayeredHexahedralMap::conflicted(int column, int row) const {
  bool known = false, unknown = false;
  for (int l = 0; l < layers_; ++l) (state(l, column, row) == CellState::kUnknown ? unknown : known) = true;
  return known && unknown;
}

size_t LayeredHexahedralMap::cells_in_state(CellState s) const {
  size_t n = 0;
  for (int l = 0; l < layers_; ++l)
    for (int r = 0; r < rows_; ++r)
      for (int c = 0; c < columns_; ++c) n += state(l, c, r) == s;
  return n;
}

size_t LayeredHexahedralMap::conflicted_columns() const {
  size_t n = 0;
  for (int r = 0; r < rows_; ++r)
    for (int c = 0; c < columns_; ++c) n += conflicted(c, r);
  return n;
}

CellState LayeredHexahedralMap::column_state(int column, int row, double height) const {
  bool all_empty = true;
  for (int l = 0; l < layers_; ++l) {
    if (settings_.z_min + l * settings_.layer_height >= height) break;
    const CellState s = state(l, column, row);
    if (s == CellState::kOccupied) return CellState::kOccupied;
    if (s != CellState::kEmpty) all_empty = false;
  }
  return all_empty ? CellState::kEmpty : CellState::kUnknown;
}

Eigen::AlignedBox2d LayeredHexahedralMap::obstacle_extent(int column, int row, double height) const {
  Eigen::AlignedBox2d box;
  for (int l = 0; l < layers_; ++l) {
    if (settings_.z_min + l * settings_.layer_height >= height) break;
    if (state(l, column, row) == CellState::kOccupied) box.extend(extent_[index(l, column, row)].cast<double>());
  }
  return box;
}

GridLayer LayeredHexahedralMap::layer_grid(int layer) const {
  GridLayer g;
  g.layer = "hexahedral_layer_" + std::to_string(layer);
  g.resolution = settings_.cell_size;
  g.origin = settings_.origin;
  g.width = columns_;
  g.height = rows_;
  g.cells.resize(static_cast<size_t>(columns_) * rows_);
  for (int r = 0; r < rows_; ++r)
    for (int c = 0; c < columns_; ++c) {
      const CellState s = state(layer, c, r);
      g.cells[static_cast<size_t>(r) * columns_ + c] = s == CellState::kOccupied ? 1.0f
                                                       : s == CellState::kEmpty  ? 0.0f
                                                                                 : std::numeric_limits<float>::quiet_NaN();
    }
  return g;
}

}  // namespace locd::icp_explorer
