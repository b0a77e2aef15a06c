// Occupancy grids in map_server's format: a YAML file naming an image (PGM or PNG) and how to
// read it (ROS map_server / Nav2 map_io):
//
//   image: warehouse.pgm       # relative to the YAML's folder, inside the map directories
//   resolution: 0.05           # m per cell
//   origin: [-10.0, -10.0, 0.0]  # x, y of the lower-left pixel's corner, yaw (must be 0)
//   negate: 0                  # 1: white is occupied
//   occupied_thresh: 0.65      # p above: occupied
//   free_thresh: 0.196         # p below: free
//   mode: trinary              # trinary | scale | raw
//
// p = (255 - value) / 255 (value / 255 with negate) per pixel, colour channels averaged. Cells
// are AMCL's: 100 occupied, 0 free, -1 unknown, and in scale mode 1..99 in between; raw mode
// keeps the pixel value (255 reads as -1). An alpha channel of 0 is unknown (scale mode).
// Image row 0 is the top of the map; grid row 0 lies at origin.y.
//
// Every size is bounded before allocation: the PGM header's or the PNG IHDR's width x height
// against max_cells, and the PGM's pixel data against its header. Errors are ConfigErrors that
// name the file and the key or what is wrong.
//
// The format is the sdk's (library locd_occupancy_map, apart from locd_sdk for OpenCV's PNG
// codec): grid_mcl localizes on it, locsim's grid worlds are made of it; each casts rays its own way.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "locd/sdk/grid.hpp"

namespace locd {

enum class MapMode { kTrinary, kScale, kRaw };

struct MapYaml {
  std::filesystem::path yaml_file;
  std::filesystem::path image_file;  // resolved
  std::string image;                 // as the YAML names it
  double resolution = 0.05;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  bool negate = false;
  double occupied_thresh = 0.65;
  double free_thresh = 0.196;
  MapMode mode = MapMode::kTrinary;
};

// Resolves the image a YAML names (relative to the YAML's folder) to a file inside the map
// directories; throws ConfigError otherwise.
using ImageResolver = std::function<std::filesystem::path(const std::string& name)>;

MapYaml read_map_yaml(const std::filesystem::path& yaml_file, const ImageResolver& resolve_image);

// An 8-bit image as read from a PGM or PNG: 1 (grey) to 4 (BGRA) channels, rows top first.
struct MapImage {
  int width = 0;
  int height = 0;
  int channels = 1;
  std::vector<uint8_t> pixels;
};
// Binary PGM (P5, maxval 1..255; other maxvals scale to 255) or PNG (8-bit grey, grey + alpha,
// RGB, RGBA), by content. max_cells bounds width x height before anything is allocated.
MapImage read_map_image(const std::filesystem::path& file, size_t max_cells);

class OccupancyMap {
 public:
  static constexpr int8_t kOccupied = 100;
  static constexpr int8_t kFree = 0;
  static constexpr int8_t kUnknown = -1;

  OccupancyMap() = default;
  OccupancyMap(GridGeometry geometry, std::vector<int8_t> cells);

  const GridGeometry& geometry() const { return geometry_; }
  const std::vector<int8_t>& cells() const { return cells_; }
  int8_t at(int row, int col) const { return cells_[static_cast<size_t>(row) * geometry_.width + col]; }
  bool occupied(int row, int col) const { return at(row, col) == kOccupied; }
  bool free(int row, int col) const { return at(row, col) == kFree; }
  size_t free_cells() const { return free_cells_; }
  size_t occupied_cells() const { return occupied_cells_; }

 private:
  GridGeometry geometry_;
  std::vector<int8_t> cells_;
  size_t free_cells_ = 0;
  size_t occupied_cells_ = 0;
};

// The cells from the image, as map_server reads them.
OccupancyMap occupancy_from_image(const MapYaml& yaml, const MapImage& image);
// read_map_yaml + read_map_image + occupancy_from_image.
OccupancyMap load_occupancy_map(const std::filesystem::path& yaml_file, const ImageResolver& resolve_image,
                                size_t max_cells);

// Writes a map as map_server's map_saver does (trinary: 254 free, 0 occupied, 205 unknown) and
// its YAML; the image is named after the YAML, with extension ".pgm" (binary P5) or ".png".
void save_occupancy_map(const OccupancyMap& map, const std::filesystem::path& yaml_file,
                        const std::string& image_extension = ".pgm");

}  // namespace locd
