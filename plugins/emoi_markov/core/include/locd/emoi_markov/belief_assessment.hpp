// Beyond the paper: does the belief vouch for its maximum? Three criteria on the grid belief,
// judged after every sensor update (README "Localization state"):
//
//   modes      connected regions (8-neighbour, on cells of `mode_cell_m`) of the smallest set of
//              cells holding `mode_region_mass` of the belief; a region counts as a mode when it
//              holds at least `min_mode_mass`
//   entropy    H = -sum p ln p over those cells; the belief's area exp(H) * cell area (m^2) is
//              the area a uniform belief of the same entropy would cover
//   peak mass  the belief's mass within `tracking_radius_m` of the estimate (on the belief grid)
//
//   fit        the RMS difference between the local map's elevations and the DSM's at the
//              estimate (best vertical offset, best distortion hypothesis, object edges left out):
//              computed by the sparse sensor model, which runs once the prior is concentrated
//
//   lost       no sensor update yet, the belief reset, or its area above `lost_area_m2`
//   uncertain  more than one mode, or the peak mass below `tracking_mass`, or the fit not
//              computed (a global update concentrated the belief: not yet checked) or above
//              `max_fit_rms_m` (the belief is concentrated on a place the local map does not fit)
//   tracking   otherwise: one mode holding (nearly) all the belief, at least tracking_mass of it
//              within tracking_radius_m of the estimate, and the local map fits there
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "locd/emoi_markov/config.hpp"
#include "locd/sdk/grid.hpp"
#include "locd/sdk/types.hpp"

namespace locd::emoi {

struct BeliefMode {
  double mass = 0.0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();      // map frame
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();  // about the mean, from the mode's cells
};

struct BeliefAssessment {
  // The estimate: the centre of the disk of tracking_radius_m holding the most belief (the
  // belief's maximum at the scale of the tracking radius: the point most likely within that
  // distance of the truth). peak_mass is that disk's mass.
  Eigen::Vector2d estimate = Eigen::Vector2d::Zero();
  std::vector<BeliefMode> modes;   // holding at least min_mode_mass each, the heaviest first
  double entropy_nats = 0.0;       // on the mode grid
  double area_m2 = 0.0;            // exp(entropy) * cell area
  double peak_mass = 0.0;          // within tracking_radius_m of the estimate (its disk's mass)
  // How well the local map fits the DSM at the estimate: the RMS shape residual there under the
  // best-fitting distortion hypothesis (m); NaN when the update did not compute it (global).
  double fit_rms_m = std::numeric_limits<double>::quiet_NaN();
  LocalizationAssessment localization;
};

// The modes of a mass grid (cells sum to one, geometry in metres): connected regions of the
// smallest set of cells holding region_mass, those holding at least min_mode_mass, the heaviest
// first.
std::vector<BeliefMode> belief_modes(const cv::Mat_<float>& mass, const GridGeometry& geometry, double region_mass,
                                     double min_mode_mass);

// -sum p ln p over the cells of a mass grid (cells sum to one).
double belief_entropy(const cv::Mat_<float>& mass);

// The mass of a belief grid within radius_m of centre (cell centres inside the disk). Only the
// cells inside `nonzero` are read (the belief is zero elsewhere).
double mass_within(const cv::Mat_<float>& belief, const cv::Rect& nonzero, const GridGeometry& geometry,
                   const Eigen::Vector2d& centre, double radius_m);

// A belief grid summed into cells of `factor` x `factor` (mass kept; partial cells at the far
// edges count). Only `nonzero` is read. geometry (out): the pooled grid's.
cv::Mat_<float> pooled_mass(const cv::Mat_<float>& belief, const cv::Rect& nonzero, const GridGeometry& geometry,
                            int factor, GridGeometry& pooled_geometry);

// The cell centre whose disk of radius_m (cell centres inside) holds the most belief, and that
// mass (out). Searched on `pooled` (the belief summed into coarser cells, pooled_geometry) first,
// then on the belief grid around the best pooled cell.
Eigen::Vector2d disk_maximum(const cv::Mat_<float>& belief, const cv::Rect& nonzero, const GridGeometry& geometry,
                             const cv::Mat_<float>& pooled, const GridGeometry& pooled_geometry, double radius_m,
                             double& mass);

// The estimate and the state from the criteria above: modes and entropy on the belief pooled to
// cells of config.mode_cell_m, the estimate and its peak mass on the belief grid itself.
// `nonzero`: the belief is zero outside it.
BeliefAssessment assess_belief(const cv::Mat_<float>& belief, const cv::Rect& nonzero, const GridGeometry& geometry,
                               const AssessmentConfig& config);

// The fit criterion on an assessment of the belief: a tracking state stands only with a fit
// (fit_rms_m finite) within config.max_fit_rms_m; sets assessment.fit_rms_m.
void apply_fit(BeliefAssessment& assessment, double fit_rms_m, const AssessmentConfig& config);

}  // namespace locd::emoi
