// DSM writers for the simulator, the tools and the tests (never linked into the plugin): a float
// GeoTIFF, or a 16-bit PNG with its YAML sidecar, both read back by load_dsm (dsm_io.hpp).
#pragma once

#include <cstdint>
#include <filesystem>

#include "locd/emoi_markov/dsm_io.hpp"

namespace locd::emoi {

// Elevation written for a cell without data.
constexpr float kGeotiffNodata = -32768.0f;
constexpr uint16_t kPngNodata = 65535;  // grey level; the sidecar names it

void write_dsm_geotiff(const ElevationMap& map, const std::filesystem::path& file);
// Quantises with `elevation_scale` (metres per grey level) above `elevation_offset` and writes the
// sidecar `<stem>.yaml` next to the image.
void write_dsm_png_with_sidecar(const ElevationMap& map, const std::filesystem::path& yaml_file,
                                double elevation_scale, double elevation_offset);

}  // namespace locd::emoi
