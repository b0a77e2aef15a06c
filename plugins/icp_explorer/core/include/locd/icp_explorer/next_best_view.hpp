// Next scan position from the layered hexahedral map (paper section 3):
//   movable m(x, y): flood fill from the robot over columns that are not occupied (inflated by
//     the robot radius, measured to the returns in the occupied cubes rather than to the cubes,
//     so a 1 m door whose jambs lie on cube boundaries stays open to a 0.3 m robot); a column
//     reached over empty columns only is movable (1), one reached
//     only through unknown columns is possibly movable (possibly_movable_weight); only columns
//     whose whole footprint (robot radius) is known empty are candidates, the rest are
//     immovable (0);
//   exploratory e(x, y): rays cast from the candidate in every layer until an occupied cube,
//     summing over the unknown cubes they cross (1 - P) * detection_from(distance);
//   resumable rs(x, y): the same sum over the unknown cubes of conflicted columns only;
//   S = m (e + beta rs)                                   (eq. 2)
//   P = alpha R(r) S T(theta), alpha = 1                  (eq. 3, 4)
// with r the path length to the candidate, R(r) = (1 - exp(-r / overlap_distance)) * (1 for
// r <= reliable_distance, exp(-(r - reliable_distance) / reliable_falloff) beyond) (fig. 3), and
// T(theta) = 1 - direction_penalty * max over earlier scan positions k within memory_radius of
// max(0, cos(theta - theta_k)): the topological map's memory, which keeps the robot from
// oscillating back to where it has scanned. The best P is the goal. Exploration is done when no
// reachable candidate's S reaches done_threshold (S is in expected newly detected cubes): the
// model is complete whatever the distance, while R and T only rank the goals.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "locd/icp_explorer/config.hpp"
#include "locd/icp_explorer/layered_hexahedral_map.hpp"
#include "locd/sdk/types.hpp"

namespace locd::icp_explorer {

struct ExplorationDecision {
  bool done = true;
  Eigen::Vector2d goal = Eigen::Vector2d::Zero();
  double heading = 0.0;  // direction from the robot to the goal
  double score = 0.0;    // P of the goal
  double potential = 0.0;  // the largest S over all candidates (decides done)
  double movable = 0.0, exploratory = 0.0, resumable = 0.0, reliability = 0.0, direction = 0.0;
  double path_length = 0.0;
  size_t candidates = 0;
};

// Per-column terms of one decision, NaN where not evaluated (for diagnostics and tests).
struct ExplorationTerms {
  GridLayer movable, exploratory, resumable, score;
};

class NextBestViewPlanner {
 public:
  explicit NextBestViewPlanner(const ExplorationSettings& settings);

  // robot: (x, y) in the map; scan_positions: earlier scan positions, oldest first.
  ExplorationDecision decide(const LayeredHexahedralMap& map, const Eigen::Vector2d& robot,
                             const std::vector<Eigen::Vector2d>& scan_positions, ExplorationTerms* terms = nullptr) const;

  // e and rs of one candidate column (eq. 2's terms), exposed for tests.
  std::pair<double, double> exploratory_and_resumable(const LayeredHexahedralMap& map, int column, int row) const;
  double reliability(double r) const;
  double direction_term(const Eigen::Vector2d& robot, const Eigen::Vector2d& candidate,
                        const std::vector<Eigen::Vector2d>& scan_positions) const;
  // m of every column, row-major; path lengths (m) from the robot, infinity where unreachable.
  std::vector<float> movable(const LayeredHexahedralMap& map, const Eigen::Vector2d& robot,
                             std::vector<float>* path_length = nullptr) const;

  const ExplorationSettings& settings() const { return settings_; }

 private:
  ExplorationSettings settings_;
};

}  // namespace locd::icp_explorer
