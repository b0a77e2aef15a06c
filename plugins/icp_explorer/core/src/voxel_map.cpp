#include "locd/icp_explorer/voxel_map.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <nanoflann.hpp>

namespace locd::icp_explorer {

namespace {
// The kd-tree indexes a float copy of the centroids: half the memory of doubles, so a search
// touches half the cache lines (the search is most of a registration's time).
struct CentroidAdaptor {
  const std::vector<Eigen::Vector3f>* points;
  size_t kdtree_get_point_count() const { return points->size(); }
  float kdtree_get_pt(size_t i, size_t dim) const { return (*points)[i][static_cast<int>(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};
using CentroidTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, CentroidAdaptor>, CentroidAdaptor, 3,
                                        uint32_t>;
}  // namespace

struct VoxelMap::KdTree {
  std::vector<Eigen::Vector3f> points;  // owned here, so moving the map keeps the tree valid
  CentroidAdaptor adaptor;
  CentroidTree tree;
  explicit KdTree(const std::vector<Eigen::Vector3d>& centroids)
      : points(to_float(centroids)), adaptor{&points}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(12)) {}
  static std::vector<Eigen::Vector3f> to_float(const std::vector<Eigen::Vector3d>& centroids) {
    std::vector<Eigen::Vector3f> out;
    out.reserve(centroids.size());
    for (const auto& c : centroids) out.push_back(c.cast<float>());
    return out;
  }
};

VoxelMap::VoxelMap(double voxel_size, int normal_neighbours)
    : voxel_size_(voxel_size), inverse_voxel_size_(1.0 / voxel_size), normal_neighbours_(normal_neighbours) {}
VoxelMap::~VoxelMap() = default;
VoxelMap::VoxelMap(VoxelMap&&) noexcept = default;
VoxelMap& VoxelMap::operator=(VoxelMap&&) noexcept = default;

void VoxelMap::clear() {
  index_.clear();
  sums_.clear();
  counts_.clear();
  scans_.clear();
  first_insert_.clear();
  inserts_ = 0;
  intensity_sums_.clear();
  intensity_count_.clear();
  points_.clear();
  normals_.clear();
  intensity_.clear();
  tree_.reset();
  normals_oriented_ = true;
}

void VoxelMap::insert(const ScanPoints& scan, const std::optional<Eigen::Vector3d>& viewpoint) {
  if (!viewpoint) normals_oriented_ = false;
  std::vector<uint32_t> touched;
  touched.reserve(scan.size());
  std::vector<char> was_touched(points_.size(), 0);
  for (size_t i = 0; i < scan.size(); ++i) {
    const Eigen::Vector3d& p = scan.points[i];
    if (!p.allFinite()) continue;
    const auto [it, inserted] = index_.try_emplace(voxel_key(p, inverse_voxel_size_), static_cast<uint32_t>(sums_.size()));
    const uint32_t v = it->second;
    if (inserted) {
      sums_.push_back(Eigen::Vector3d::Zero());
      counts_.push_back(0);
      scans_.push_back(0);
      first_insert_.push_back(inserts_);
      intensity_sums_.push_back(0.0);
      intensity_count_.push_back(0);
      points_.push_back(p);
      normals_.push_back(Eigen::Vector3d::Zero());
      intensity_.push_back(std::numeric_limits<float>::quiet_NaN());
      was_touched.push_back(0);
    }
    sums_[v] += p;
    ++counts_[v];
    if (scan.has_intensity() && std::isfinite(scan.intensity[i])) {
      intensity_sums_[v] += scan.intensity[i];
      ++intensity_count_[v];
      intensity_[v] = static_cast<float>(intensity_sums_[v] / intensity_count_[v]);
    }
    points_[v] = sums_[v] / counts_[v];
    if (!was_touched[v]) {
      was_touched[v] = 1;
      touched.push_back(v);
      if (scans_[v] < std::numeric_limits<uint16_t>::max()) ++scans_[v];
    }
  }
  ++inserts_;
  tree_ = std::make_unique<KdTree>(points_);
  refresh_normals(touched, viewpoint);
}

size_t VoxelMap::carve(const std::vector<Eigen::Vector3d>& ray_ends, const Eigen::Vector3d& viewpoint, int min_rays,
                       double end_margin) {
  if (points_.empty() || !viewpoint.allFinite()) return 0;
  std::vector<uint16_t> rays_through(points_.size(), 0);
  const double plane_crossing_radius = 0.3 * voxel_size_;
  for (const Eigen::Vector3d& end : ray_ends) {
    if (!end.allFinite()) continue;
    const Eigen::Vector3d d = end - viewpoint;
    const double length = d.norm();
    if (length <= end_margin) continue;
    const Eigen::Vector3d u = d / length;
    // Amanatides-Woo over the model's voxels, from the scanner to end_margin before the end.
    VoxelKey k = voxel_key(viewpoint, inverse_voxel_size_);
    Eigen::Vector3i step;
    Eigen::Vector3d t_max, t_delta;
    for (int a = 0; a < 3; ++a) {
      if (std::abs(u[a]) < 1e-12) {
        step[a] = 0;
        t_max[a] = t_delta[a] = std::numeric_limits<double>::infinity();
        continue;
      }
      step[a] = u[a] > 0 ? 1 : -1;
      const double boundary = (k[a] + (u[a] > 0 ? 1 : 0)) * voxel_size_;
      t_max[a] = (boundary - viewpoint[a]) / u[a];
      t_delta[a] = voxel_size_ / std::abs(u[a]);
    }
    const double stop = length - end_margin;
    double t_exit = t_max.minCoeff();
    for (;;) {
      // The ray crosses voxel k over [t_enter, t_exit]; it counts when it leaves it before `stop`.
      if (t_exit > stop) break;
      const auto it = index_.find(k);
      if (it != index_.end()) {
        const uint32_t v = it->second;
        const Eigen::Vector3d& n = normals_[v];
        // Not through a surface the ray grazes, nor one it ends on (its end on the voxel's plane:
        // a ray reaching a floor or wall at a shallow angle crosses that surface's own voxels).
        const double facing = n.dot(u);
        if (scans_[v] == 1 && !n.isZero() && std::abs(facing) >= 0.3 &&
            std::abs(n.dot(end - points_[v])) >= voxel_size_ && rays_through[v] < 65535) {
          // Where the ray crosses the voxel's surface plane: near the centroid, a surface there
          // would have been hit (beside an object's edge the crossing falls off the surface).
          const double t = n.dot(points_[v] - viewpoint) / facing;
          if ((viewpoint + t * u - points_[v]).norm() <= plane_crossing_radius) ++rays_through[v];
        }
      }
      int a = 0;
      if (t_max[1] < t_max[a]) a = 1;
      if (t_max[2] < t_max[a]) a = 2;
      k[a] += step[a];
      t_max[a] += t_delta[a];
      t_exit = t_max.minCoeff();
    }
  }
  // Compact the voxel arrays without the carved voxels.
  std::vector<uint32_t> new_index(points_.size(), std::numeric_limits<uint32_t>::max());
  uint32_t kept = 0;
  for (size_t v = 0; v < points_.size(); ++v) {
    if (scans_[v] == 1 && rays_through[v] >= min_rays) continue;
    new_index[v] = kept;
    if (kept != v) {
      sums_[kept] = sums_[v];
      counts_[kept] = counts_[v];
      scans_[kept] = scans_[v];
      first_insert_[kept] = first_insert_[v];
      intensity_sums_[kept] = intensity_sums_[v];
      intensity_count_[kept] = intensity_count_[v];
      points_[kept] = points_[v];
      normals_[kept] = normals_[v];
      intensity_[kept] = intensity_[v];
    }
    ++kept;
  }
  const size_t removed = points_.size() - kept;
  if (removed == 0) return 0;
  for (auto* v : {&sums_, &points_, &normals_}) v->resize(kept);
  counts_.resize(kept);
  scans_.resize(kept);
  first_insert_.resize(kept);
  intensity_sums_.resize(kept);
  intensity_count_.resize(kept);
  intensity_.resize(kept);
  for (auto it = index_.begin(); it != index_.end();) {
    if (new_index[it->second] == std::numeric_limits<uint32_t>::max()) {
      it = index_.erase(it);
    } else {
      it->second = new_index[it->second];
      ++it;
    }
  }
  tree_ = points_.empty() ? nullptr : std::make_unique<KdTree>(points_);
  return removed;
}

void VoxelMap::refresh_normals(const std::vector<uint32_t>& touched, const std::optional<Eigen::Vector3d>& viewpoint) {
  const size_t k = static_cast<size_t>(normal_neighbours_);
  std::vector<uint32_t> indices(k);
  std::vector<float> distances(k);
  for (uint32_t v : touched) {
    size_t found = tree_->tree.knnSearch(tree_->points[v].data(), k, indices.data(), distances.data());
    // Only neighbours close enough to share the surface (a few voxels away) define a normal.
    const double reach2 = 9.0 * voxel_size_ * voxel_size_ * normal_neighbours_ / 4.0;
    size_t close = 0;
    while (close < found && distances[close] <= reach2) ++close;
    found = close;
    if (found < 5) {
      normals_[v].setZero();
      continue;
    }
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (size_t j = 0; j < found; ++j) mean += points_[indices[j]];
    mean /= static_cast<double>(found);
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    for (size_t j = 0; j < found; ++j) {
      const Eigen::Vector3d d = points_[indices[j]] - mean;
      covariance += d * d.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
    const Eigen::Vector3d eigenvalues = solver.eigenvalues();  // ascending
    // A normal only where the neighbourhood is a plane: spread in two directions (not a line),
    // the third spread well below them.
    if (eigenvalues(2) <= 0.0 || eigenvalues(1) < 0.05 * eigenvalues(2) || eigenvalues(0) > 0.1 * eigenvalues(1)) {
      normals_[v].setZero();
      continue;
    }
    Eigen::Vector3d normal = solver.eigenvectors().col(0).normalized();
    if (viewpoint && normal.dot(*viewpoint - points_[v]) < 0.0) normal = -normal;
    normals_[v] = normal;
  }
}

bool VoxelMap::nearest(const Eigen::Vector3d& q, size_t& index, double& distance2) const {
  size_t indices[2];
  double distances2[2];
  if (nearest_two_within(q, std::numeric_limits<double>::infinity(), indices, distances2) == 0) return false;
  index = indices[0];
  distance2 = distances2[0];
  return true;
}

namespace {
// nanoflann result set for the two nearest neighbours with an initial bound: subtrees farther
// than the bound (or than the second nearest found so far) are never visited.
class BoundedNearestTwo {
 public:
  using DistanceType = float;
  using IndexType = uint32_t;
  using CountType = size_t;
  explicit BoundedNearestTwo(float bound2) : distance2_{bound2, bound2} {}
  size_t size() const { return count_; }
  bool full() const { return count_ == 2; }
  bool addPoint(float distance2, uint32_t index) {
    if (distance2 >= distance2_[1]) return true;
    if (distance2 < distance2_[0]) {
      distance2_[1] = distance2_[0];
      index_[1] = index_[0];
      distance2_[0] = distance2;
      index_[0] = index;
    } else {
      distance2_[1] = distance2;
      index_[1] = index;
    }
    if (count_ < 2) ++count_;
    return true;
  }
  float worstDist() const { return distance2_[1]; }
  const float* distances2() const { return distance2_; }
  const uint32_t* indices() const { return index_; }

 private:
  float distance2_[2];
  uint32_t index_[2] = {0, 0};
  size_t count_ = 0;
};
}  // namespace

size_t VoxelMap::nearest_two_within(const Eigen::Vector3d& q, double bound2, size_t index[2], double distance2[2]) const {
  if (!tree_ || points_.empty()) return 0;
  // The search runs in float: the bound is widened and the second distance lowered by a
  // millimetre-fraction so that both stay bounds; the nearest distance is recomputed in double.
  constexpr double kSlack = 1e-5;  // m, well above float rounding of coordinates within 100 m
  const double bound = std::sqrt(bound2);
  const float search_bound2 =
      std::isfinite(bound2) ? static_cast<float>((bound + kSlack) * (bound + kSlack)) : std::numeric_limits<float>::max();
  BoundedNearestTwo result(search_bound2);
  const Eigen::Vector3f query = q.cast<float>();
  tree_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams(10, 0.0f, false));
  const size_t found = result.size();
  if (found > 0) {
    index[0] = result.indices()[0];
    distance2[0] = (points_[index[0]] - q).squaredNorm();
  }
  if (found > 1) {
    index[1] = result.indices()[1];
    const double second = std::max(0.0, (points_[index[1]] - q).norm() - kSlack);  // float order: lower bound
    distance2[1] = second * second;
  } else {
    index[1] = index[0];
    distance2[1] = bound2;
  }
  if (found == 1 && distance2[0] >= bound2) return 0;  // only within the slack
  if (found == 2 && distance2[1] >= bound2) {          // second only within the slack
    distance2[1] = bound2;
    return distance2[0] < bound2 ? 1 : 0;
  }
  return found;
}

ScanPoints VoxelMap::downsampled(double voxel_size) const {
  std::vector<Eigen::Vector3f> points;
  points.reserve(points_.size());
  std::vector<float> intensity;
  intensity.reserve(points_.size());
  for (size_t i = 0; i < points_.size(); ++i) {
    points.push_back(points_[i].cast<float>());
    intensity.push_back(intensity_[i]);
  }
  ScanPoints out = voxel_downsample(points, intensity, voxel_size);
  return out;
}

}  // namespace locd::icp_explorer
