#include "locd/emoi_markov/dsm_writer.hpp"

#include <cpl_conv.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

#include "locd/emoi_markov/gdal_dataset.hpp"

namespace fs = std::filesystem;

namespace locd::emoi {

void write_dsm_geotiff(const ElevationMap& map, const fs::path& file) {
  register_gdal();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (!driver) throw std::runtime_error("GDAL has no GTiff driver");
  const int width = map.geometry.width, height = map.geometry.height;
  Dataset dataset(driver->Create(file.c_str(), width, height, 1, GDT_Float32, nullptr));
  if (!dataset) throw std::runtime_error("cannot create GeoTIFF '" + file.string() + "': " + CPLGetLastErrorMsg());
  const double res = map.geometry.resolution;
  double transform[6] = {map.geometry.origin.x(), res, 0.0, map.geometry.origin.y() + height * res, 0.0, -res};
  dataset->SetGeoTransform(transform);
  GDALRasterBand* band = dataset->GetRasterBand(1);
  const float nodata = kGeotiffNodata;
  band->SetNoDataValue(nodata);
  cv::Mat_<float> image(height, width);
  for (int r = 0; r < height; ++r) {
    const float* src = map.elevation.ptr<float>(height - 1 - r);
    float* dst = image.ptr<float>(r);
    for (int c = 0; c < width; ++c) dst[c] = std::isfinite(src[c]) ? src[c] : nodata;
  }
  if (band->RasterIO(GF_Write, 0, 0, width, height, image.ptr<float>(), width, height, GDT_Float32, 0, 0) != CE_None) {
    throw std::runtime_error("cannot write GeoTIFF '" + file.string() + "': " + CPLGetLastErrorMsg());
  }
}

void write_dsm_png_with_sidecar(const ElevationMap& map, const fs::path& yaml_file, double elevation_scale,
                                double elevation_offset) {
  register_gdal();
  const int width = map.geometry.width, height = map.geometry.height;
  const fs::path image_file = fs::path(yaml_file).replace_extension(".png");
  GDALDriver* memory = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDriver* png = GetGDALDriverManager()->GetDriverByName("PNG");
  if (!memory || !png) throw std::runtime_error("GDAL lacks the MEM or PNG driver");
  Dataset staging(memory->Create("", width, height, 1, GDT_UInt16, nullptr));
  cv::Mat_<uint16_t> image(height, width);
  for (int r = 0; r < height; ++r) {
    const float* src = map.elevation.ptr<float>(height - 1 - r);
    uint16_t* dst = image.ptr<uint16_t>(r);
    for (int c = 0; c < width; ++c) {
      if (!std::isfinite(src[c])) {
        dst[c] = kPngNodata;
        continue;
      }
      const double level = std::round((src[c] - elevation_offset) / elevation_scale);
      dst[c] = static_cast<uint16_t>(std::clamp(level, 0.0, static_cast<double>(kPngNodata - 1)));
    }
  }
  if (staging->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, width, height, image.ptr<uint16_t>(), width, height,
                                          GDT_UInt16, 0, 0) != CE_None) {
    throw std::runtime_error("cannot stage the PNG raster: " + std::string(CPLGetLastErrorMsg()));
  }
  Dataset written(png->CreateCopy(image_file.c_str(), staging.get(), FALSE, nullptr, nullptr, nullptr));
  if (!written) throw std::runtime_error("cannot write PNG '" + image_file.string() + "': " + CPLGetLastErrorMsg());
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "image" << YAML::Value << image_file.filename().string()
      << YAML::Key << "resolution" << YAML::Value << map.geometry.resolution << YAML::Key << "origin"
      << YAML::Value << YAML::Flow << YAML::BeginSeq << map.geometry.origin.x() << map.geometry.origin.y()
      << YAML::EndSeq << YAML::Key << "elevation_scale" << YAML::Value << elevation_scale << YAML::Key
      << "elevation_offset" << YAML::Value << elevation_offset << YAML::Key << "nodata" << YAML::Value << kPngNodata
      << YAML::EndMap;
  std::ofstream file(yaml_file);
  file << out.c_str() << "\n";
  if (!file) throw std::runtime_error("cannot write '" + yaml_file.string() + "'");
}

}  // namespace locd::emoi
