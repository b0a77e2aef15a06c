#include "locd/sim_icp_explorer/surface_coverage.hpp"

#include <cmath>
#include <deque>
#include <map>

#include "locd/sdk/geometry.hpp"

namespace locd::sim {

namespace {
constexpr int64_t kOffset = 1 << 20;
}

int64_t SurfaceCoverage::key(const Eigen::Vector3f& p) const {
  const int64_t x = static_cast<int64_t>(std::floor(p.x() / voxel_size_)) + kOffset;
  const int64_t y = static_cast<int64_t>(std::floor(p.y() / voxel_size_)) + kOffset;
  const int64_t z = static_cast<int64_t>(std::floor(p.z() / voxel_size_)) + kOffset;
  return (x << 42) | (y << 21) | z;
}

int64_t SurfaceCoverage::surface_voxel(const Eigen::Vector3f& hit, const Eigen::Vector3f& sensor) const {
  const Eigen::Vector3f back = sensor - hit;
  const float length = back.norm();
  return key(length > 1e-6f ? Eigen::Vector3f(hit + back * (1e-3f / length)) : hit);
}

SurfaceCoverage::SurfaceCoverage(const IndoorWorld& world, const Scanner3DConfig& reference_scanner,
                                 double voxel_size, double grid_step, double robot_radius,
                                 const Eigen::Vector2d& start, int scan_every, double z_low, double z_high)
    : voxel_size_(voxel_size), z_low_(z_low), z_high_(z_high) {
  Scanner3DConfig config = reference_scanner;
  config.range_stddev = 0.0;
  config.intensity_stddev = 0.0;
  const Scanner3D scanner(config);
  const Eigen::AlignedBox3d& b = world.bounds();
  const int columns = static_cast<int>(std::floor((b.max().x() - b.min().x()) / grid_step));
  const int rows = static_cast<int>(std::floor((b.max().y() - b.min().y()) / grid_step));
  auto centre = [&](int c, int r) {
    return Eigen::Vector2d(b.min().x() + (c + 0.5) * grid_step, b.min().y() + (r + 0.5) * grid_step);
  };
  auto free = [&](int c, int r) {
    return c >= 0 && r >= 0 && c < columns && r < rows &&
           world.footprint_free(centre(c, r), robot_radius, 0.05, config.sensor_height + 0.1);
  };
  std::vector<char> seen(static_cast<size_t>(columns) * rows, 0);
  std::deque<std::pair<int, int>> queue;
  const int c0 = static_cast<int>(std::floor((start.x() - b.min().x()) / grid_step));
  const int r0 = static_cast<int>(std::floor((start.y() - b.min().y()) / grid_step));
  if (free(c0, r0)) {
    queue.emplace_back(c0, r0);
    seen[static_cast<size_t>(r0) * columns + c0] = 1;
  }
  std::vector<Eigen::Vector2d> scanned;
  while (!queue.empty()) {
    const auto [c, r] = queue.front();
    queue.pop_front();
    positions_.push_back(centre(c, r));
    if (c % scan_every == 0 && r % scan_every == 0) scanned.push_back(centre(c, r));
    const int dc[4] = {1, -1, 0, 0}, dr[4] = {0, 0, 1, -1};
    for (int k = 0; k < 4; ++k) {
      const int nc = c + dc[k], nr = r + dr[k];
      if (nc < 0 || nr < 0 || nc >= columns || nr >= rows) continue;
      char& s = seen[static_cast<size_t>(nr) * columns + nc];
      if (s || !free(nc, nr)) continue;
      s = 1;
      queue.emplace_back(nc, nr);
    }
  }
  std::mt19937_64 rng(1);
  const IndoorWorld static_world(world.boxes(), {});
  for (const auto& xy : scanned) {
    const SimulatedScan s = scanner.scan(static_world, Pose2(xy.x(), xy.y(), 0.0).to_isometry(), 0.0, 0, rng);
    for (size_t i = 0; i < s.points_in_world.size(); ++i)
      if (counted(s.points_in_world[i])) reference_.insert(surface_voxel(s.points_in_world[i], s.sensor_in_world));
  }
}

void SurfaceCoverage::add(const SimulatedScan& scan, const IndoorWorld& world) {
  const size_t first_person = world.boxes().size();
  for (size_t i = 0; i < scan.points_in_world.size(); ++i) {
    if (static_cast<size_t>(scan.hit_object[i]) >= first_person) continue;
    const int64_t k = surface_voxel(scan.points_in_world[i], scan.sensor_in_world);
    if (reference_.count(k)) covered_.insert(k);
  }
}

double SurfaceCoverage::ratio() const {
  return reference_.empty() ? 0.0 : static_cast<double>(covered_.size()) / static_cast<double>(reference_.size());
}

}  // namespace locd::sim
