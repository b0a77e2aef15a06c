// Resampling for particle filters.
#pragma once

#include <random>
#include <vector>

namespace locd {

// 1 / sum(w_i^2) over normalised weights; n for uniform weights, 1 for a single survivor.
double effective_sample_size(const std::vector<double>& weights);

// Low-variance (systematic) resampling: `count` indices drawn with one random offset
// (Probabilistic Robotics, Table 4.4). Weights need not be normalised; all-zero weights
// resample uniformly.
std::vector<size_t> low_variance_resample(const std::vector<double>& weights, size_t count,
                                          std::mt19937_64& rng);

}  // namespace locd
