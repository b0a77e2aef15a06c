// The real KITTI pair of ../shared/realdata/kitti_pair (README there): two consecutive Velodyne
// HDL-64E scans and the transform that takes the source into the target frame. Read with PCL's
// PLY reader; the intensity field is `scalar_intensity` (0-215 scale) or `intensity`.
#pragma once

#include <pcl/PCLPointCloud2.h>
#include <pcl/io/ply_io.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace locd::bench {

struct RealCloud {
  std::vector<Eigen::Vector3f> points;
  std::vector<float> intensity;  // empty when the file has none
};

inline RealCloud read_ply_cloud(const std::filesystem::path& file) {
  pcl::PCLPointCloud2 blob;
  if (pcl::io::loadPLYFile(file.string(), blob) != 0) throw std::runtime_error("cannot read " + file.string());
  int offset[4] = {-1, -1, -1, -1};
  for (const auto& field : blob.fields) {
    if (field.datatype != pcl::PCLPointField::FLOAT32) continue;
    const std::string& n = field.name;
    const int slot = n == "x" ? 0 : n == "y" ? 1 : n == "z" ? 2 : (n == "scalar_intensity" || n == "intensity") ? 3 : -1;
    if (slot >= 0) offset[slot] = static_cast<int>(field.offset);
  }
  if (offset[0] < 0 || offset[1] < 0 || offset[2] < 0) throw std::runtime_error(file.string() + ": no float x, y, z");
  RealCloud cloud;
  const size_t n = static_cast<size_t>(blob.width) * blob.height;
  for (size_t i = 0; i < n; ++i) {
    const uint8_t* p = blob.data.data() + i * blob.point_step;
    float v[4] = {0, 0, 0, 0};
    for (int k = 0; k < 4; ++k)
      if (offset[k] >= 0) std::memcpy(&v[k], p + offset[k], sizeof(float));
    cloud.points.emplace_back(v[0], v[1], v[2]);
    if (offset[3] >= 0) cloud.intensity.push_back(v[3]);
  }
  return cloud;
}

struct KittiPair {
  RealCloud source, target;
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
};

// The folder of the real data: $LOCD_REALDATA, else ../shared/realdata beside the source tree.
inline std::filesystem::path realdata_directory(const std::filesystem::path& source_dir) {
  const char* s = std::getenv("LOCD_REALDATA");
  return s ? std::filesystem::path(s) : source_dir / ".." / "shared" / "realdata";
}

inline KittiPair load_kitti_pair(const std::filesystem::path& folder) {
  KittiPair pair;
  pair.source = read_ply_cloud(folder / "kitti_source.ply");
  pair.target = read_ply_cloud(folder / "kitti_target.ply");
  std::ifstream in(folder / "kitti_T_target_source.txt");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (!(in >> m(r, c))) throw std::runtime_error((folder / "kitti_T_target_source.txt").string() + ": not a 4x4 matrix");
  pair.T_target_source.matrix() = m;
  return pair;
}

}  // namespace locd::bench
