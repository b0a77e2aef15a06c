#include "locd/sdk/resampling.hpp"

#include <numeric>

namespace locd {

double effective_sample_size(const std::vector<double>& weights) {
  const double sum = std::accumulate(weights.begin(), weights.end(), 0.0);
  if (sum <= 0.0) return 0.0;
  double sq = 0.0;
  for (double w : weights) sq += (w / sum) * (w / sum);
  return 1.0 / sq;
}

std::vector<size_t> low_variance_resample(const std::vector<double>& weights, size_t count,
                                          std::mt19937_64& rng) {
  std::vector<size_t> indices;
  indices.reserve(count);
  if (weights.empty() || count == 0) return indices;
  double total = std::accumulate(weights.begin(), weights.end(), 0.0);
  const bool uniform = !(total > 0.0);
  if (uniform) total = static_cast<double>(weights.size());
  const double step = total / static_cast<double>(count);
  const double r = std::uniform_real_distribution<double>(0.0, step)(rng);
  size_t i = 0;
  double cumulative = uniform ? 1.0 : weights[0];
  for (size_t m = 0; m < count; ++m) {
    const double u = r + static_cast<double>(m) * step;
    while (u > cumulative && i + 1 < weights.size()) {
      ++i;
      cumulative += uniform ? 1.0 : weights[i];
    }
    indices.push_back(i);
  }
  return indices;
}

}  // namespace locd
