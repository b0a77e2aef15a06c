#include "locd/emoi_markov/dsm_io.hpp"

#include <cpl_conv.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>

#include "locd/emoi_markov/gdal_dataset.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sdk/params.hpp"

namespace fs = std::filesystem;

namespace locd::emoi {
namespace {

Dataset open_raster(const fs::path& file) {
  register_gdal();
  Dataset dataset(static_cast<GDALDataset*>(GDALOpenEx(file.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY,
                                                      nullptr, nullptr, nullptr)));
  if (!dataset) {
    throw ConfigError("DSM '" + file.string() + "' cannot be opened as a raster: " + CPLGetLastErrorMsg());
  }
  if (dataset->GetRasterCount() < 1) throw ConfigError("DSM '" + file.string() + "' has no raster band");
  return dataset;
}

void check_size(const fs::path& file, int width, int height, size_t max_cells) {
  if (width < 1 || height < 1) throw ConfigError("DSM '" + file.string() + "' is empty");
  const size_t cells = static_cast<size_t>(width) * static_cast<size_t>(height);
  if (cells > max_cells) {
    throw ConfigError("DSM '" + file.string() + "' has " + std::to_string(width) + " x " +
                      std::to_string(height) + " = " + std::to_string(cells) +
                      " cells; the server allows at most " + std::to_string(max_cells) + " (limits.max_map_cells)");
  }
}

// Reads band 1 as doubles, top row first (image order).
cv::Mat_<double> read_band(GDALDataset& dataset, const fs::path& file) {
  const int width = dataset.GetRasterXSize(), height = dataset.GetRasterYSize();
  cv::Mat_<double> pixels(height, width);
  GDALRasterBand* band = dataset.GetRasterBand(1);
  if (band->RasterIO(GF_Read, 0, 0, width, height, pixels.ptr<double>(), width, height, GDT_Float64, 0, 0) !=
      CE_None) {
    throw ConfigError("DSM '" + file.string() + "': reading the raster failed: " + CPLGetLastErrorMsg());
  }
  return pixels;
}

ElevationMap load_geotiff(const fs::path& file, size_t max_cells) {
  Dataset dataset = open_raster(file);
  const int width = dataset->GetRasterXSize(), height = dataset->GetRasterYSize();
  check_size(file, width, height, max_cells);
  double transform[6];
  if (dataset->GetGeoTransform(transform) != CE_None) {
    throw ConfigError("DSM '" + file.string() +
                      "' has no geotransform; a GeoTIFF DSM needs one (or use a YAML sidecar with resolution and origin)");
  }
  if (transform[2] != 0.0 || transform[4] != 0.0) {
    throw ConfigError("DSM '" + file.string() + "' is rotated (geotransform terms 2, 4 = " +
                      std::to_string(transform[2]) + ", " + std::to_string(transform[4]) +
                      "); allowed: north-up rasters only (0, 0)");
  }
  const double dx = transform[1], dy = transform[5];
  if (!(dx > 0) || !std::isfinite(dx) || !(std::abs(std::abs(dy) - dx) <= 1e-9 * dx)) {
    throw ConfigError("DSM '" + file.string() + "' has pixel size " + std::to_string(dx) + " x " +
                      std::to_string(dy) + "; allowed: square cells (|dy| = dx > 0)");
  }
  GDALRasterBand* band = dataset->GetRasterBand(1);
  int has_nodata = 0;
  const double nodata = band->GetNoDataValue(&has_nodata);
  int has_scale = 0, has_offset = 0;
  double scale = band->GetScale(&has_scale), offset = band->GetOffset(&has_offset);
  if (!has_scale) scale = 1.0;
  if (!has_offset) offset = 0.0;
  cv::Mat_<double> pixels = read_band(*dataset, file);

  ElevationMap map;
  map.geometry.resolution = dx;
  map.geometry.width = width;
  map.geometry.height = height;
  const bool north_up = dy < 0;
  map.geometry.origin = {transform[0], north_up ? transform[3] + height * dy : transform[3]};
  map.elevation.create(height, width);
  for (int r = 0; r < height; ++r) {
    const double* src = pixels.ptr<double>(north_up ? height - 1 - r : r);
    float* dst = map.elevation.ptr<float>(r);
    for (int c = 0; c < width; ++c) {
      const double v = src[c];
      const bool missing = !std::isfinite(v) || (has_nodata && v == nodata);
      dst[c] = missing ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(v * scale + offset);
    }
  }
  return map;
}

ElevationMap load_sidecar(const fs::path& yaml_file, size_t max_cells) {
  Params params = Params::load_file(yaml_file.string());
  params.expect_only({"image", "resolution", "origin", "elevation_scale", "elevation_offset", "nodata"});
  const std::string image = params.required_text("image");
  const fs::path image_path(image);
  if (image_path.is_absolute() || image.find("..") != std::string::npos) {
    params.fail("image", "names '" + image + "'; allowed: a file name relative to the sidecar, without '..'");
  }
  const fs::path directory = fs::weakly_canonical(yaml_file.parent_path());
  const fs::path resolved = fs::weakly_canonical(directory / image_path);
  const auto relative = resolved.lexically_relative(directory);
  if (relative.empty() || *relative.begin() == "..") {
    params.fail("image", "'" + image + "' resolves outside the sidecar's directory");
  }
  if (!fs::is_regular_file(resolved)) params.fail("image", "'" + image + "' does not exist next to the sidecar");
  const double resolution = params.required_number("resolution", Range::positive());
  const std::vector<double> origin = params.numbers("origin", {}, 2);
  if (origin.size() != 2) params.fail("origin", "is missing; allowed: [x, y] in metres");
  const double scale = params.required_number("elevation_scale", Range::positive());
  const double offset = params.number("elevation_offset", 0.0);
  const bool has_nodata = params.has("nodata");
  const double nodata = has_nodata ? params.number("nodata", 0.0, Range::closed(0, 65535)) : 0.0;

  Dataset dataset = open_raster(resolved);
  const int width = dataset->GetRasterXSize(), height = dataset->GetRasterYSize();
  check_size(resolved, width, height, max_cells);
  const GDALDataType type = dataset->GetRasterBand(1)->GetRasterDataType();
  if (type != GDT_UInt16 && type != GDT_Byte) {
    throw ConfigError("DSM image '" + resolved.string() + "' has pixel type " + GDALGetDataTypeName(type) +
                      "; allowed: 16-bit (or 8-bit) grey PNG/PGM");
  }
  cv::Mat_<double> pixels = read_band(*dataset, resolved);
  ElevationMap map;
  map.geometry.resolution = resolution;
  map.geometry.origin = {origin[0], origin[1]};
  map.geometry.width = width;
  map.geometry.height = height;
  map.elevation.create(height, width);
  for (int r = 0; r < height; ++r) {
    const double* src = pixels.ptr<double>(height - 1 - r);  // image top row = north
    float* dst = map.elevation.ptr<float>(r);
    for (int c = 0; c < width; ++c) {
      dst[c] = (has_nodata && src[c] == nodata) ? std::numeric_limits<float>::quiet_NaN()
                                                : static_cast<float>(src[c] * scale + offset);
    }
  }
  return map;
}

std::string lower_extension(const fs::path& file) {
  std::string ext = file.extension().string();
  for (auto& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return ext;
}

}  // namespace

size_t ElevationMap::valid_cells() const {
  size_t n = 0;
  for (int r = 0; r < elevation.rows; ++r) {
    const float* row = elevation.ptr<float>(r);
    for (int c = 0; c < elevation.cols; ++c) n += std::isfinite(row[c]) ? 1 : 0;
  }
  return n;
}

ElevationMap load_dsm(const fs::path& file, size_t max_cells) {
  const std::string ext = lower_extension(file);
  ElevationMap map;
  if (ext == ".tif" || ext == ".tiff") {
    map = load_geotiff(file, max_cells);
  } else if (ext == ".yaml" || ext == ".yml") {
    map = load_sidecar(file, max_cells);
  } else {
    throw ConfigError("DSM '" + file.string() + "' has extension '" + ext +
                      "'; allowed: .tif/.tiff (GeoTIFF) or .yaml/.yml (sidecar naming a 16-bit PNG/PGM)");
  }
  if (map.valid_cells() == 0) throw ConfigError("DSM '" + file.string() + "' has no cell with data (all nodata)");
  return map;
}

}  // namespace locd::emoi
