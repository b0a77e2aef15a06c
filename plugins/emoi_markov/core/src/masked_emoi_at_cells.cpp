// MaskedEmoiMatcher::match_at: EMOI_M (and the shape residual) at listed matching-grid cells by
// direct sums over the observed cells M, split into its steps: the term table of the observed
// cells, the check that a cell's reach holds only data, and the sums at one cell.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "locd/emoi_markov/masked_emoi.hpp"

namespace locd::emoi {
namespace {
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
}  // namespace

// The observed cells of the largest disk as direct-sum terms, sorted by radius bucket: a cell
// counts in the smallest radius whose disk holds it (the disks are nested, so one pass over the
// largest disk serves every radius, the buckets summed up afterwards).
struct detail::DirectSumTerms {
  std::vector<int> row_offset, column_offset;
  std::vector<long> linear;         // row_offset * columns + column_offset
  std::vector<float> r2_m;          // r^2, m^2
  std::vector<float> robot_value;   // the robot's elevation at the cell (T)
  std::vector<float> robot_square;  // T^2
  std::vector<size_t> bucket_end;   // per bucket (radii in ascending order): one past its last term
  // Per bucket, sum r^2 and the count: what the data-mask sums give where every cell has data.
  std::vector<float> bucket_moment, bucket_count;
  size_t size() const { return linear.size(); }
};

namespace {

using detail::DirectSumTerms;

// Sums of one cell's terms: sum r^2 e (moment_elevation), sum r^2 over cells with data (moment),
// the count of cells with data, and the shape sums (elevation d = e - ground: sum d, sum d^2,
// sum T d; robot side: sum T, sum T^2).
struct CellSums {
  double moment_elevation = 0.0, moment = 0.0, count = 0.0;
  double elevation = 0.0, elevation_square = 0.0, cross = 0.0;
  double robot = 0.0, robot_square = 0.0, shape_count = 0.0;
};

// One bucket where every cell has data: sum r^2 e in four independent partial sums (the adds do
// not wait on each other).
inline float moment_sum(const float* e, const DirectSumTerms& terms, size_t& t, size_t end) {
  float part[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  for (; t + 4 <= end; t += 4) {
    part[0] += terms.r2_m[t] * e[terms.linear[t]];
    part[1] += terms.r2_m[t + 1] * e[terms.linear[t + 1]];
    part[2] += terms.r2_m[t + 2] * e[terms.linear[t + 2]];
    part[3] += terms.r2_m[t + 3] * e[terms.linear[t + 3]];
  }
  for (; t < end; ++t) part[0] += terms.r2_m[t] * e[terms.linear[t]];
  return (part[0] + part[1]) + (part[2] + part[3]);
}

// One bucket where every cell has data, with the shape sums gathered in the same pass over the
// cells the shape counts (weight w: 1, or 0 at the DSM's edges; two partial sums each): returns
// sum r^2 e and adds sum w d, sum w d^2, sum w T d, sum w T, sum w T^2, sum w to sums.
inline float moment_and_shape_sum(const float* e, const float* w, float ground, const DirectSumTerms& terms,
                                  size_t& t, size_t end, CellSums& sums) {
  float moment[2] = {0.0f, 0.0f}, elevation[2] = {0.0f, 0.0f}, square[2] = {0.0f, 0.0f}, cross[2] = {0.0f, 0.0f};
  float robot[2] = {0.0f, 0.0f}, robot_square[2] = {0.0f, 0.0f}, count[2] = {0.0f, 0.0f};
  for (; t + 2 <= end; t += 2) {
    const long i0 = terms.linear[t], i1 = terms.linear[t + 1];
    const float v0 = e[i0], v1 = e[i1], w0 = w[i0], w1 = w[i1];
    const float d0 = v0 - ground, d1 = v1 - ground;
    moment[0] += terms.r2_m[t] * v0;
    moment[1] += terms.r2_m[t + 1] * v1;
    elevation[0] += w0 * d0;
    elevation[1] += w1 * d1;
    square[0] += w0 * d0 * d0;
    square[1] += w1 * d1 * d1;
    cross[0] += w0 * terms.robot_value[t] * d0;
    cross[1] += w1 * terms.robot_value[t + 1] * d1;
    robot[0] += w0 * terms.robot_value[t];
    robot[1] += w1 * terms.robot_value[t + 1];
    robot_square[0] += w0 * terms.robot_square[t];
    robot_square[1] += w1 * terms.robot_square[t + 1];
    count[0] += w0;
    count[1] += w1;
  }
  for (; t < end; ++t) {
    const long i = terms.linear[t];
    const float v = e[i], d = v - ground, weight = w[i];
    moment[0] += terms.r2_m[t] * v;
    elevation[0] += weight * d;
    square[0] += weight * d * d;
    cross[0] += weight * terms.robot_value[t] * d;
    robot[0] += weight * terms.robot_value[t];
    robot_square[0] += weight * terms.robot_square[t];
    count[0] += weight;
  }
  sums.elevation += elevation[0] + elevation[1];
  sums.elevation_square += square[0] + square[1];
  sums.cross += cross[0] + cross[1];
  sums.robot += robot[0] + robot[1];
  sums.robot_square += robot_square[0] + robot_square[1];
  sums.shape_count += count[0] + count[1];
  return moment[0] + moment[1];
}

// The shape residual over M (cells with data), elevations relative to the candidate's ground:
// min_c mean (T - e - c)^2 = var(T) + var(e) - 2 cov(T, e), in m^2; NaN without overlap.
inline float shape_residual(const CellSums& s) {
  const double n = s.shape_count;
  if (n < 0.5) return std::numeric_limits<float>::quiet_NaN();
  const double residual = (s.robot_square - s.robot * s.robot / n) + (s.elevation_square - s.elevation * s.elevation / n) -
                          2.0 * (s.cross - s.robot * s.elevation / n);
  return static_cast<float>(std::max(residual, 0.0) / n);
}

}  // namespace

MaskedEmoiMatcher::Match MaskedEmoiMatcher::match_at(const cv::Mat_<float>& patch, const std::vector<cv::Point>& cells,
                                                     bool shape) const {
  std::vector<std::vector<Offset>> disks;
  Match out = robot_side(patch, disks);
  std::vector<size_t> by_radius(radii_m_.size());
  std::iota(by_radius.begin(), by_radius.end(), size_t{0});
  std::sort(by_radius.begin(), by_radius.end(), [&](size_t a, size_t b) { return radii_m_[a] < radii_m_[b]; });
  const DirectSumTerms terms = direct_sum_terms(patch, disks[by_radius.back()], by_radius);
  const int n_cells = static_cast<int>(cells.size());
  for (size_t k = 0; k < radii_m_.size(); ++k) out.dsm_emoi.push_back(cv::Mat_<float>(1, n_cells, kNaN));
  if (shape) out.shape_residual = cv::Mat_<float>(1, n_cells, kNaN);
  for (int i = 0; i < n_cells; ++i) {
    const cv::Point& x = cells[i];
    if (x.x < 0 || x.y < 0 || x.x >= coarse_.geometry.width || x.y >= coarse_.geometry.height) continue;
    if (!std::isfinite(ground_(x.y, x.x))) continue;
    cell_match(x, terms, by_radius, disks, shape, i, out);
  }
  return out;
}

DirectSumTerms MaskedEmoiMatcher::direct_sum_terms(const cv::Mat_<float>& patch,
                                                                      const std::vector<Offset>& largest_disk,
                                                                      const std::vector<size_t>& by_radius) const {
  const size_t radii = radii_m_.size();
  const int cols = coarse_.geometry.width;
  const double cell = coarse_.geometry.resolution;
  struct Term {
    int dr, dc;
    double r2_m;
    size_t bucket;
  };
  std::vector<Term> sorted;
  for (const Offset& o : largest_disk) {
    size_t bucket = radii - 1;
    for (size_t b = 0; b < radii; ++b) {
      const int radius = radius_in_cells(radii_m_[by_radius[b]], cell);
      if (o.dr * o.dr + o.dc * o.dc < radius * radius) {
        bucket = b;
        break;
      }
    }
    sorted.push_back({o.dr, o.dc, o.r2_m, bucket});
  }
  std::stable_sort(sorted.begin(), sorted.end(), [](const Term& a, const Term& b) { return a.bucket < b.bucket; });
  DirectSumTerms terms;
  for (auto* column : {&terms.row_offset, &terms.column_offset}) column->reserve(sorted.size());
  terms.linear.reserve(sorted.size());
  terms.r2_m.reserve(sorted.size());
  terms.robot_value.reserve(sorted.size());
  terms.bucket_end.assign(radii, 0);
  terms.bucket_moment.assign(radii, 0.0f);
  terms.bucket_count.assign(radii, 0.0f);
  for (size_t t = 0, b = 0; b < radii; ++b) {
    for (; t < sorted.size() && sorted[t].bucket == b; ++t) {
      const Term& term = sorted[t];
      terms.row_offset.push_back(term.dr);
      terms.column_offset.push_back(term.dc);
      terms.linear.push_back(static_cast<long>(term.dr) * cols + term.dc);
      terms.r2_m.push_back(static_cast<float>(term.r2_m));
      terms.robot_value.push_back(patch(patch_radius_ + term.dr, patch_radius_ + term.dc));
      terms.robot_square.push_back(terms.robot_value.back() * terms.robot_value.back());
      terms.bucket_moment[b] += terms.r2_m.back();
      terms.bucket_count[b] += 1.0f;
    }
    terms.bucket_end[b] = t;
  }
  return terms;
}

bool MaskedEmoiMatcher::reach_has_only_data(const cv::Point& x) const {
  const int reach = patch_radius_;
  const int rows = coarse_.geometry.height, cols = coarse_.geometry.width;
  const bool inside = x.x >= reach && x.y >= reach && x.x + reach < cols && x.y + reach < rows;
  return inside && nodata_integral_(x.y + reach + 1, x.x + reach + 1) - nodata_integral_(x.y - reach, x.x + reach + 1) -
                           nodata_integral_(x.y + reach + 1, x.x - reach) + nodata_integral_(x.y - reach, x.x - reach) ==
                       0;
}

void MaskedEmoiMatcher::cell_match(const cv::Point& x, const DirectSumTerms& terms, const std::vector<size_t>& by_radius,
                                   const std::vector<std::vector<Offset>>& disks, bool shape, int column,
                                   Match& out) const {
  const int rows = coarse_.geometry.height, cols = coarse_.geometry.width;
  const int reach = patch_radius_;
  const double ground = ground_(x.y, x.x) - reference_;
  const long centre = static_cast<long>(x.y) * cols + x.x;
  const bool inside = x.x >= reach && x.y >= reach && x.x + reach < cols && x.y + reach < rows;
  // Every cell of the patch's reach has data: only sum r^2 e is left to add up.
  const bool all_data = reach_has_only_data(x);
  const float* elevation = filled_.ptr<float>(0);
  const float* valid = valid_.ptr<float>(0);
  const float* shape_valid = shape_valid_.ptr<float>(0);
  const auto on_map = [&](size_t t) {
    if (inside) return true;
    const int r = x.y + terms.row_offset[t], c = x.x + terms.column_offset[t];
    return r >= 0 && c >= 0 && r < rows && c < cols;
  };
  CellSums sums;  // running over the buckets, smallest radius first
  size_t t = 0;
  for (size_t b = 0; b < by_radius.size(); ++b) {
    const size_t end = terms.bucket_end[b];
    if (all_data) {
      sums.moment_elevation +=
          shape ? moment_and_shape_sum(elevation + centre, shape_valid + centre, static_cast<float>(ground), terms, t, end, sums)
                : moment_sum(elevation + centre, terms, t, end);
      sums.moment += terms.bucket_moment[b];
      sums.count += terms.bucket_count[b];
    } else {
      float moment_elevation = 0.0f, moment = 0.0f, count = 0.0f;
      for (; t < end; ++t) {
        if (!on_map(t)) continue;
        const long index = centre + terms.linear[t];
        moment_elevation += terms.r2_m[t] * elevation[index];
        moment += terms.r2_m[t] * valid[index];
        count += valid[index];
      }
      sums.moment_elevation += moment_elevation;
      sums.moment += moment;
      sums.count += count;
    }
    const size_t k = by_radius[b];
    // eq. 7 on M: sum r^2 (e(x + k) - e(x)) / n / R^2
    if (sums.count > 0.5 && !disks[k].empty()) {
      out.dsm_emoi[k](0, column) =
          static_cast<float>((sums.moment_elevation - ground * sums.moment) / sums.count / (radii_m_[k] * radii_m_[k]));
    }
  }
  if (!shape) return;
  if (!all_data) {
    for (size_t q = 0; q < terms.size(); ++q) {
      if (!on_map(q)) continue;
      const long index = centre + terms.linear[q];
      if (shape_valid[index] == 0.0f) continue;
      const double d = elevation[index] - ground, v = terms.robot_value[q];
      sums.elevation += d;
      sums.elevation_square += d * d;
      sums.cross += v * d;
      sums.robot += v;
      sums.robot_square += v * v;
      sums.shape_count += 1.0;
    }
  }
  out.shape_residual(0, column) = shape_residual(sums);
}

}  // namespace locd::emoi
