// The layered hexahedral map (paper section 3.1): the space between z_min and z_max is cut into
// horizontal layers of height layer_height, each a grid of cubes (cell_size x cell_size). A cube's
// detection probability is P(i, j, k) = T[kappa, n]: per scan, n points fell in it at distance
// kappa from the scanner, and T = 1 - exp(-n / nu(kappa)) with nu = the number of returns that
// counts as a detection at that distance (fill * the returns a facing cube gets from the
// scanner's angular resolution, clamped to [1, points_for_detection]); scans combine as
// independent detections, P = 1 - prod(1 - T_s). Rays from the scanner to every point mark the
// cubes they cross as seen through. A cube is occupied when P >= occupied_probability, empty
// when seen through and not occupied, unknown otherwise. A column (j, k) is conflicted when some
// of its layers are unknown and others known: a partially scanned (occluded) place.
// Each cube also keeps the horizontal extent of the returns that fell in it, so traversability
// can measure the clearance to the surface itself rather than to the whole cube (a door's jamb
// lying on a cube boundary would otherwise close a 1 m door to a 0.3 m robot).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "locd/icp_explorer/config.hpp"
#include "locd/sdk/types.hpp"

namespace locd::icp_explorer {

enum class CellState : uint8_t { kUnknown = 0, kEmpty = 1, kOccupied = 2 };

class LayeredHexahedralMap {
 public:
  explicit LayeredHexahedralMap(const LayeredMapSettings& settings);

  // One scan, points and scanner position in the map frame.
  void integrate(const std::vector<Eigen::Vector3d>& points_in_map, const Eigen::Vector3d& scanner_in_map);

  // T[kappa, n] and the returns a facing cube gets at distance kappa.
  double detection(double kappa, double n) const;
  double expected_returns(double kappa) const;
  // Probability that a scan from distance kappa detects a surface in a cube (exploration gain).
  double detection_from(double kappa) const;

  int columns() const { return columns_; }
  int rows() const { return rows_; }
  int layers() const { return layers_; }
  const LayeredMapSettings& settings() const { return settings_; }
  bool column_of(const Eigen::Vector2d& xy, int& column, int& row) const;
  Eigen::Vector2d column_centre(int column, int row) const;
  double layer_centre_z(int layer) const;

  double probability(int layer, int column, int row) const { return probability_[index(layer, column, row)]; }
  CellState state(int layer, int column, int row) const;
  bool conflicted(int column, int row) const;
  size_t cells_in_state(CellState s) const;
  size_t conflicted_columns() const;

  // Traversability for a robot of `height`: occupied when any layer below height is occupied,
  // empty when all those layers are empty, unknown otherwise.
  CellState column_state(int column, int row, double height) const;
  // Horizontal extent of the returns in the column's occupied cubes below `height` (empty box
  // when none is occupied).
  Eigen::AlignedBox2d obstacle_extent(int column, int row, double height) const;

  // Layer as a grid: occupied 1, empty 0, unknown NaN (for diagnostics and tests).
  GridLayer layer_grid(int layer) const;

 private:
  size_t index(int layer, int column, int row) const {
    return (static_cast<size_t>(layer) * rows_ + row) * columns_ + column;
  }
  LayeredMapSettings settings_;
  int columns_ = 0, rows_ = 0, layers_ = 0;
  std::vector<float> probability_;
  std::vector<uint16_t> seen_through_;
  std::vector<Eigen::AlignedBox2f> extent_;  // per cube, horizontal extent of its returns
};

}  // namespace locd::icp_explorer
