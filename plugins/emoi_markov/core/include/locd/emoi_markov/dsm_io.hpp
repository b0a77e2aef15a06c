// Digital surface models (DSM): a float elevation raster with its grid geometry. NaN marks nodata
// cells; they are masked everywhere (never read as ground).
//
// Two file forms, both opened through GDAL so the raster size is known before any allocation:
//  - GeoTIFF (.tif/.tiff): north-up geotransform (no rotation, square cells), the band's nodata
//    value and scale/offset are honoured;
//  - a YAML sidecar (.yaml/.yml), like a map server's, naming a 16-bit PNG or PGM next to it:
//      image: hills.png        # relative to the sidecar, inside its directory
//      resolution: 0.1         # m per cell
//      origin: [x, y]          # map position of the lower-left corner of the image
//      elevation_scale: 0.01   # metres per grey level
//      elevation_offset: 0.0   # metres at grey level 0
//      nodata: 65535           # optional grey level meaning "no data"
#pragma once

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "locd/sdk/grid.hpp"

namespace locd::emoi {

struct ElevationMap {
  GridGeometry geometry;       // row 0 at origin.y (south), column 0 at origin.x (west)
  cv::Mat_<float> elevation;   // height x width, metres, NaN = nodata

  size_t valid_cells() const;
};

// Loads a DSM; throws ConfigError naming the file, the key or value and what is allowed.
// Rasters with more than max_cells cells are refused before their pixels are read.
ElevationMap load_dsm(const std::filesystem::path& file, size_t max_cells);

// The writers (simulator, tools, tests) are in tools/: locd/emoi_markov/dsm_writer.hpp.

}  // namespace locd::emoi
