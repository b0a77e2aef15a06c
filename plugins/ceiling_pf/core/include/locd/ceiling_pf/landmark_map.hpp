// The ceiling landmark map: positions only (all landmarks look alike), plus an index that
// answers "the N landmarks nearest to a point" in constant time (Table 1, line 2).
//
// Map file (resolved through the server's map directories):
//   frame_id: map
//   ceiling_height: 2.42           # m above the floor
//   landmarks: [[x, y], ...]       # m, map frame
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <string>
#include <vector>

#include "locd/ceiling_pf/config.hpp"
#include "locd/sdk/params.hpp"

namespace locd::ceiling_pf {

struct LandmarkMap {
  std::string frame_id = "map";
  double ceiling_height = 0.0;
  std::vector<Eigen::Vector2d> landmarks;
  std::string id(size_t index) const { return "L" + std::to_string(index); }
};

// Errors (ConfigError) name the key, the entry and what is allowed; max_landmarks bounds the
// list before anything is stored.
LandmarkMap parse_landmark_map(const Params& params, size_t max_landmarks);
LandmarkMap load_landmark_map(const std::string& file, size_t max_landmarks);
std::string landmark_map_yaml(const LandmarkMap& map);

// Exact k-nearest landmarks on a uniform grid: every cell stores the landmarks that can be
// among the k nearest to any point in the cell (those not farther from the cell than the k-th
// smallest farthest distance), so a query scans a short list. Points outside the grid fall back
// to a scan of all landmarks.
// The k nearest landmarks of a point, nearest first (k <= kMaxCandidates).
using LandmarkCandidates = std::array<int, kMaxCandidates>;

class NearestLandmarkIndex {
 public:
  // margin: how far beyond the landmarks' bounding box the grid reaches. k in [1, kMaxCandidates]
  // (ConfigError otherwise); a map with fewer landmarks answers with all of them.
  NearestLandmarkIndex(std::vector<Eigen::Vector2d> landmarks, int k, double cell_size, double margin,
                       size_t max_cells);

  // Writes up to k indices, nearest first, into out; returns how many.
  int nearest(const Eigen::Vector2d& point, LandmarkCandidates& out) const;
  int nearest_brute_force(const Eigen::Vector2d& point, LandmarkCandidates& out) const;

  int k() const { return k_; }
  const std::vector<Eigen::Vector2d>& landmarks() const { return landmarks_; }
  size_t cells() const { return static_cast<size_t>(columns_) * rows_; }
  double mean_candidates() const;

 private:
  int select(const Eigen::Vector2d& point, const int* candidates, int count, LandmarkCandidates& out) const;

  std::vector<Eigen::Vector2d> landmarks_;
  int k_;
  double cell_size_;
  Eigen::Vector2d origin_;
  int columns_ = 0, rows_ = 0;
  std::vector<uint32_t> cell_start_;  // CSR: candidates of cell c in [cell_start_[c], cell_start_[c+1])
  std::vector<int> candidates_;
  std::vector<int> all_;
};

}  // namespace locd::ceiling_pf
