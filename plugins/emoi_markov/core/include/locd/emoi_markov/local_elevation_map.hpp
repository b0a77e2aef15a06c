// The robot's own elevation map (paper section II), built in the odometry frame from tilted 2D
// laser scans (eq. 1-5) or 3D point clouds, with the max-height update of eq. 5.
//
// Beyond the paper: the grid scrolls with the robot (fixed size, recentred when the robot comes
// near an edge); a cell written more than `refresh_distance_m` of travel ago is overwritten by a
// new return (the max of eq. 5 then runs over recent returns only, placed with recent odometry),
// and a cell not refreshed within `memory_distance_m` is forgotten, so odometry drift does not
// pile old, misplaced heights under the robot's current EMOI disk.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <deque>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "locd/emoi_markov/config.hpp"
#include "locd/emoi_markov/emoi.hpp"
#include "locd/sdk/types.hpp"

namespace locd::emoi {

// Eq. 1-2: the laser frame in base_link for a scanner on a tilt axis. The tilt axis sits at
// (x_tilt, 0, z_tilt) in base_link; the laser's sensing point at (x_laser, 0, z_laser) in the
// tilt frame; tilt_angle rotates about the tilt frame's y axis (positive looks down).
Eigen::Isometry3d tilting_laser_pose(double x_tilt, double z_tilt, double x_laser, double z_laser,
                                     double tilt_angle);

// Eq. 4: roll-pitch-yaw rotation RPY(phi = yaw, theta = pitch, psi = roll).
Eigen::Matrix3d rpy_rotation(double yaw, double pitch, double roll);

struct InsertStatistics {
  size_t inserted = 0;        // points written into a cell
  size_t out_of_grid = 0;     // points outside the local grid
  size_t invalid = 0;         // NaN / inf ranges or points, no-return beams
};

class LocalElevationMap {
 public:
  explicit LocalElevationMap(const LocalMapConfig& config);

  // Moves the grid so that `position` (odom frame) lies in its central half; keeps what overlaps.
  void follow(const Eigen::Vector2d& position);

  // Eq. 1-5: a scan taken with base_link at T_odom_base (position, roll, pitch, yaw).
  InsertStatistics insert_scan(const LaserScan& scan, const Eigen::Isometry3d& T_odom_base,
                               double travelled_m);
  // Points in the sensor frame (sensor_pose: sensor in base_link).
  InsertStatistics insert_cloud(const PointCloud& cloud, const Eigen::Isometry3d& T_odom_base,
                                double travelled_m);
  // Eq. 5 for one point in the odom frame. False when outside the grid.
  bool insert_point(const Eigen::Vector3d& point_odom, double travelled_m);

  // The EMOI of every radius at `position` (odom frame) over observed, not forgotten cells;
  // centre_elevation is the robot's ground height in the odom frame.
  std::vector<PointEmoi> emoi(const Eigen::Vector2d& position, double centre_elevation,
                              const std::vector<double>& radii_m, double travelled_m) const;

  // The odometry position (odom frame) at a travel mark; kept for the cells the map still
  // remembers, so a cell can be re-placed under a hypothesis of the odometry's distortion.
  void record_pose(double travelled_m, const Eigen::Vector2d& odom_position);
  // The recorded position at a travel mark (linear between records, clamped at the ends).
  Eigen::Vector2d recorded_position(double travelled_m) const;

  // The remembered cells around the robot, once for every hypothesis of the odometry's
  // distortion: position relative to the robot (odom frame) as odometry placed it, the odometry's
  // displacement from where the cell was written to the robot, P_odom(t) - position, and the
  // elevation. reach_m bounds the relative position.
  struct PatchCells {
    std::vector<Eigen::Vector2f> relative, since_written;
    std::vector<float> elevation;
  };
  PatchCells patch_cells(const Eigen::Vector2d& position, double reach_m, double travelled_m) const;

  // The robot-centred patch the masked match reads: (2 radius_cells + 1)^2 cells of cell_m,
  // aligned with the map frame (odom rotated by heading_offset = map yaw - odom yaw), each the
  // mean observed elevation of the local-map cells falling into it, minus centre_elevation; NaN
  // unobserved. Each local-map cell is placed relative to the robot under the hypothesis that the
  // true displacement is `distortion` times the odometry's (a scale-rotation, so it commutes with
  // the heading rotation): a cell written at travel t moves from p - position to
  //   (p - position) + (distortion - I) (P_odom(t) - position).
  // With the identity it is the local map as odometry placed it.
  static cv::Mat_<float> bin_patch(const PatchCells& cells, double heading_offset, double cell_m, int radius_cells,
                                   double centre_elevation,
                                   const Eigen::Matrix2d& distortion = Eigen::Matrix2d::Identity());
  // patch_cells + bin_patch, reaching far enough for this distortion.
  cv::Mat_<float> robot_patch(const Eigen::Vector2d& position, double heading_offset, double cell_m,
                              int radius_cells, double centre_elevation, double travelled_m,
                              const Eigen::Matrix2d& distortion = Eigen::Matrix2d::Identity()) const;
  // The reach patch_cells needs for a patch and distortions up to |B - I| = max_correction.
  double patch_reach_m(const Eigen::Vector2d& position, double cell_m, int radius_cells, double max_correction) const;

  // Observed elevations (NaN where unknown or forgotten) and the grid geometry (odom frame).
  cv::Mat_<float> observed(double travelled_m) const;
  GridGeometry geometry() const;
  size_t observed_cells(double travelled_m) const;

 private:
  LocalMapConfig config_;
  int cells_ = 0;
  Eigen::Vector2i origin_cell_{0, 0};  // odom-frame cell index of grid (0, 0)
  bool anchored_ = false;
  cv::Mat_<float> elevation_;          // NaN = never seen
  cv::Mat_<float> seen_at_;            // travel (m) when last written
  std::deque<std::pair<double, Eigen::Vector2d>> trajectory_;  // (travel, odom position), increasing travel
};

// bin_patch for many distortions of one set of cells (the hypotheses of one sensor update): the
// cells' map-frame positions are rotated once, and the cells written at the same travel mark
// (the same displacement since written) are moved together.
class PatchBinner {
 public:
  // max_correction: the largest |distortion - I| (Frobenius) patch() will be asked for; cells no
  // such distortion can move into the patch are left out once here.
  PatchBinner(const LocalElevationMap::PatchCells& cells, double heading_offset, double cell_m, int radius_cells,
              double centre_elevation, double max_correction = std::numeric_limits<double>::infinity());
  // The same as LocalElevationMap::bin_patch(cells, ..., distortion). Throws InputError for a
  // distortion beyond max_correction.
  cv::Mat_<float> patch(const Eigen::Matrix2d& distortion = Eigen::Matrix2d::Identity()) const;

 private:
  struct Run {  // consecutive cells sharing since_written
    size_t begin, end;
    Eigen::Vector2f since_written;
  };
  Eigen::Matrix2d rotation_;
  double cell_m_;
  int radius_cells_;
  double centre_elevation_;
  double max_correction_;
  std::vector<Eigen::Vector2f> in_cells_;  // map frame, matching cells, as odometry placed them
  std::vector<float> elevation_;
  std::vector<Run> runs_;
};

}  // namespace locd::emoi
