// Writing the model to disk: PCD (binary, fields x y z intensity) or PLY (binary little endian,
// vertex x y z intensity), the two formats PCL, CloudCompare and MeshLab read. File names are
// generated here from the robot id (reduced to [A-Za-z0-9_-]), the scan count and a UTC stamp;
// a request never supplies a path.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "locd/icp_explorer/config.hpp"
#include "locd/icp_explorer/scan_points.hpp"

namespace locd::icp_explorer {

void write_pcd(const std::filesystem::path& file, const ScanPoints& points);
void write_ply(const std::filesystem::path& file, const ScanPoints& points);

// "<robot>_map_<scans>scans_<YYYYmmddTHHMMSS>Z.<pcd|ply>"; unique within the directory.
std::filesystem::path generated_map_file(const std::filesystem::path& directory, const std::string& robot_id,
                                         size_t scans, MapFileFormat format);

}  // namespace locd::icp_explorer
