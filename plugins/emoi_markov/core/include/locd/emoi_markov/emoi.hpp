// Elevation moment of inertia (EMOI), paper eq. 6-7, for every cell of a DSM.
//
//   EMOI_R(c) = 1/n * sum_{k : |k| < R'} r_k^2 (e(c + k) - e(c))        (eq. 7)
//
// with R' = round(R / resolution) cells, r_k = |k| * resolution in metres, and n the number of
// cells in the disk that hold data (nodata and off-map cells are left out of the sum and of n).
// Beyond the paper, every layer is divided by R^2 ("normalised EMOI", metres): one similarity
// sigma in metres then fits every radius (the same as eq. 8 with sigma_R = sigma * R^2).
// A cell without data gets NaN.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "locd/emoi_markov/dsm_io.hpp"

namespace locd::emoi {

// Progress of a long computation: fraction done in [0, 1] and what is running.
using ProgressCallback = std::function<void(double fraction, const std::string& stage)>;

int radius_in_cells(double radius_m, double resolution_m);  // R' of eq. 7, >= 1

// Reference: the O(cells * R'^2) double loop of eq. 7 (tests and the baseline benchmark).
cv::Mat_<double> emoi_direct(const ElevationMap& map, double radius_m);

// Every radius at once by convolution (eq. 7 split into three disk convolutions done with
// OpenCV's real DFT): sum r^2 e, e(c) * sum r^2 and n. Same result as emoi_direct up to
// rounding. Throws ConfigError if a radius does not fit in the map.
std::vector<cv::Mat_<double>> emoi_fft(const ElevationMap& map, const std::vector<double>& radii_m,
                                       const ProgressCallback& progress = {});

// EMOI at one cell of a (partial) local map, over the cells that hold data only; the centre
// elevation is given (the robot's ground height). coverage = n / (cells in the disk).
struct PointEmoi {
  double emoi = 0.0;      // normalised as the layers (divided by R^2)
  double coverage = 0.0;  // observed fraction of the disk, [0, 1]
  size_t observed = 0;
};
PointEmoi emoi_at(const cv::Mat_<float>& elevation, double resolution_m, int row, int col,
                  double centre_elevation, double radius_m);

// The precomputed layers of a DSM, one per radius, as floats (what the Markov update reads).
struct EmoiLayers {
  std::vector<double> radii_m;
  std::vector<cv::Mat_<float>> layers;
};

EmoiLayers to_layers(const std::vector<double>& radii_m, const std::vector<cv::Mat_<double>>& emoi);

}  // namespace locd::emoi
