// Beyond the paper: EMOI over exactly the cells the robot has observed ("masked EMOI").
//
// A robot that has seen only part of a disk cannot reproduce the DSM's full-disk EMOI (the
// paper's failure at location A). Here the DSM side uses the same relative cells M the robot
// observed (rotated into the map frame by the heading), for every candidate cell x at once:
//
//   EMOI_M(x) = 1/n_M(x) * sum_{k in M} r_k^2 (e(x + k) - e(x)) / R^2        (eq. 7 on M)
//
// which is three DFT correlations per radius on a coarser matching grid (DSM max-pooled, like
// the max-height local map of eq. 5; the centre e(x) min-pooled, the ground the robot stands on).
// The resulting likelihood (eq. 8 multiplied over radii) is interpolated to the belief grid.
// An error d of the robot's ground height (odometry z, slope under a distorted local map) shifts
// every radius by d * mean(r^2)/R^2 over M; with ground_offset_stddev_m > 0 that offset is
// marginalised in closed form (Gaussian prior), so only the shape across radii must match.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "locd/emoi_markov/dsm_io.hpp"
#include "locd/emoi_markov/markov_grid.hpp"

namespace locd::emoi {

namespace detail {
struct DirectSumTerms;  // match_at's table of the observed cells (masked_emoi.cpp)
}  // namespace detail

class MaskedEmoiMatcher {
 public:
  // match_resolution_m is rounded to a whole number of DSM cells (at least one).
  // shape_edge_step_m > 0: the shape residual leaves out the matching cells where the DSM steps
  // by more than this within one cell (3 x 3 neighbourhood): object edges, whose tops a ground
  // robot's laser does not see (its max-height map holds the face's highest return there).
  MaskedEmoiMatcher(const ElevationMap& dsm, std::vector<double> radii_m, double match_resolution_m,
                    double shape_edge_step_m = 0.0);

  int factor() const { return factor_; }                        // DSM cells per matching cell
  double cell_m() const { return coarse_.geometry.resolution; }
  int patch_radius() const { return patch_radius_; }          // patch side = 2 * patch_radius + 1
  const ElevationMap& surface() const { return coarse_; }     // max-pooled DSM

  struct Match {
    std::vector<double> robot_emoi;           // per radius, over the observed cells
    std::vector<double> coverage;             // per radius, observed fraction of the disk
    std::vector<size_t> observed;             // per radius, |M|
    std::vector<double> offset_gain;          // per radius, d EMOI / d(centre elevation) = -mean r^2 / R^2 over M
    std::vector<cv::Mat_<float>> dsm_emoi;    // per radius, EMOI_M(x) on the matching grid (or 1 x N at listed cells)
    // match_at with shape: per listed cell, the mean squared difference between the robot's
    // elevations and the DSM's over M after the best vertical offset (m^2, NaN: no overlap), the
    // DSM's edge cells left out (shape_edge_step_m).
    cv::Mat_<float> shape_residual;
  };
  // patch: map-aligned, centred on the robot, matching-grid cells, value = elevation minus the
  // robot's ground elevation, NaN = not observed. Size (2 patch_radius + 1)^2.
  Match match(const cv::Mat_<float>& patch) const;
  // The same EMOI_M at the listed matching-grid cells only (x = column, y = row), by direct sums
  // over M: dsm_emoi[radius] is 1 x cells.size(). For a few thousand cells this is cheaper than
  // the DFTs of match(). With shape, also the elevation residual of the local map at each cell
  // (Match::shape_residual).
  Match match_at(const cv::Mat_<float>& patch, const std::vector<cv::Point>& cells, bool shape = false) const;

  // log p(z|x) for every entry of match.dsm_emoi (the matching grid, or the listed cells), floored
  // (cells without data get the floor).
  cv::Mat_<float> coarse_log_likelihood(const Match& match, const SensorModelConfig& sensor,
                                        std::vector<double>* weights = nullptr) const;
  // p(z|x) on the DSM (belief) grid: exp on the matching grid, then bilinear interpolation.
  cv::Mat_<float> likelihood(const Match& match, const SensorModelConfig& sensor, int fine_rows, int fine_cols,
                             std::vector<double>* weights = nullptr) const;
  // A matching-grid field (likelihood) interpolated bilinearly to the DSM grid.
  cv::Mat_<float> to_fine(const cv::Mat_<float>& coarse, int fine_rows, int fine_cols) const;
  // The same for a window of the matching grid (coarse_rect) whose cells outside it are all
  // equal: returns the DSM-grid values on fine_rect (out) = coarse_rect scaled and clipped to the
  // fine grid; every fine cell outside fine_rect interpolates that constant. Equal to to_fine on
  // the whole grid inside fine_rect when coarse_rect keeps one constant cell around what varies.
  cv::Mat_<float> to_fine_window(const cv::Mat_<float>& coarse_window, const cv::Rect& coarse_rect, int fine_rows,
                                 int fine_cols, cv::Rect& fine_rect) const;
  // A DSM-grid field (belief) summed into matching-grid cells (mass is kept).
  cv::Mat_<float> pool(const cv::Mat_<float>& fine) const;
  // The same when the field is zero outside `nonzero` (only that window is read).
  cv::Mat_<float> pool(const cv::Mat_<float>& fine, const cv::Rect& nonzero) const;

 private:
  // The robot side of eq. 7 on M (robot_emoi, coverage, observed, offset_gain) and, per radius,
  // the observed cells of its disk (row offset, column offset, r^2 in m^2).
  struct Offset {
    int dr, dc;
    double r2_m;
  };
  Match robot_side(const cv::Mat_<float>& patch, std::vector<std::vector<Offset>>& disks) const;
  // match_at's steps: the observed cells of the largest disk as a term table sorted by radius
  // bucket (by_radius: radius indices, ascending); whether every cell within the patch's reach
  // of x has data; and the sums at one listed cell written into column `column` of out.
  detail::DirectSumTerms direct_sum_terms(const cv::Mat_<float>& patch, const std::vector<Offset>& largest_disk,
                                          const std::vector<size_t>& by_radius) const;
  bool reach_has_only_data(const cv::Point& x) const;
  void cell_match(const cv::Point& x, const detail::DirectSumTerms& terms, const std::vector<size_t>& by_radius,
                  const std::vector<std::vector<Offset>>& disks, bool shape, int column, Match& out) const;

  std::vector<double> radii_m_;
  int factor_ = 1;
  int patch_radius_ = 1;
  ElevationMap coarse_;            // max-pooled
  cv::Mat_<float> ground_;         // centre elevations (the pooled DSM)
  cv::Mat_<float> filled_, valid_; // pooled DSM minus reference_ (0 where no data), 1 where data
  cv::Mat_<float> shape_valid_;    // 1 where data and no edge (shape_edge_step_m), else 0
  cv::Mat_<int> nodata_integral_;  // integral image of the cells without data (match_at's fast path)
  double reference_ = 0.0;
  int padded_rows_ = 0, padded_cols_ = 0;
  cv::Mat elevation_spectrum_, valid_spectrum_;
};

}  // namespace locd::emoi
