#include "locd/icp_explorer/map_file.hpp"

#include <cmath>
#include <ctime>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace locd::icp_explorer {

namespace {
std::vector<float> interleaved(const ScanPoints& points) {
  std::vector<float> data;
  data.reserve(points.size() * 4);
  for (size_t i = 0; i < points.size(); ++i) {
    data.push_back(static_cast<float>(points.points[i].x()));
    data.push_back(static_cast<float>(points.points[i].y()));
    data.push_back(static_cast<float>(points.points[i].z()));
    const float intensity = points.has_intensity() ? points.intensity[i] : 0.0f;
    data.push_back(std::isfinite(intensity) ? intensity : 0.0f);
  }
  return data;
}

void write_all(const std::filesystem::path& file, const std::string& header, const std::vector<float>& data) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error("cannot open '" + file.string() + "' for writing");
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  out.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size() * sizeof(float)));
  if (!out) throw std::runtime_error("writing '" + file.string() + "' failed");
}
}  // namespace

void write_pcd(const std::filesystem::path& file, const ScanPoints& points) {
  const std::string n = std::to_string(points.size());
  const std::string header = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\n"
                             "SIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH " + n + "\nHEIGHT 1\n"
                             "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + n + "\nDATA binary\n";
  write_all(file, header, interleaved(points));
}

void write_ply(const std::filesystem::path& file, const ScanPoints& points) {
  const std::string header = "ply\nformat binary_little_endian 1.0\ncomment locd icp_explorer map\nelement vertex " +
                             std::to_string(points.size()) +
                             "\nproperty float x\nproperty float y\nproperty float z\nproperty float intensity\n"
                             "end_header\n";
  write_all(file, header, interleaved(points));
}

std::filesystem::path generated_map_file(const std::filesystem::path& directory, const std::string& robot_id,
                                         size_t scans, MapFileFormat format) {
  std::string robot;
  for (char c : robot_id) robot += (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-') ? c : '_';
  if (robot.empty()) robot = "robot";
  char stamp[32];
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  std::strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%SZ", &utc);
  const char* extension = format == MapFileFormat::kPcd ? ".pcd" : ".ply";
  const std::string base = robot + "_map_" + std::to_string(scans) + "scans_" + stamp;
  std::filesystem::path file = directory / (base + extension);
  for (int k = 1; std::filesystem::exists(file); ++k) file = directory / (base + "_" + std::to_string(k) + extension);
  return file;
}

}  // namespace locd::icp_explorer
