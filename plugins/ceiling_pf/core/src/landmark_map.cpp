#include "locd/ceiling_pf/landmark_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>

#include "locd/sdk/errors.hpp"

namespace locd::ceiling_pf {

LandmarkMap parse_landmark_map(const Params& params, size_t max_landmarks) {
  params.expect_only({"frame_id", "ceiling_height", "landmarks"});
  LandmarkMap map;
  map.frame_id = params.text("frame_id", "map");
  map.ceiling_height = params.required_number("ceiling_height", Range::open(0.0, 100.0));
  if (!params.has("landmarks")) params.fail("landmarks", "is missing; expected a list of [x, y] positions");
  const YAML::Node list = params.node()["landmarks"];
  if (!list.IsSequence() || list.size() == 0) {
    params.fail("landmarks", "must be a non-empty list of [x, y] positions");
  }
  if (list.size() > max_landmarks) {
    params.fail("landmarks", "has " + std::to_string(list.size()) + " entries; allowed at most " +
                                 std::to_string(max_landmarks));
  }
  map.landmarks.reserve(list.size());
  for (size_t i = 0; i < list.size(); ++i) {
    const YAML::Node entry = list[i];
    const std::string name = "landmarks[" + std::to_string(i) + "]";
    bool ok = entry.IsSequence() && entry.size() == 2;
    double xy[2] = {0, 0};
    for (size_t j = 0; ok && j < 2; ++j) {
      try {
        xy[j] = entry[j].as<double>();
      } catch (const YAML::Exception&) {
        ok = false;
      }
      ok = ok && std::isfinite(xy[j]) && std::abs(xy[j]) < 1e6;
    }
    if (!ok) {
      const YAML::Mark m = entry.Mark();
      throw ConfigError("parameter '" + params.key_path(name) + "' (line " + std::to_string(m.line + 1) +
                        ", column " + std::to_string(m.column + 1) +
                        ") must be [x, y] with finite numbers of magnitude below 1e6");
    }
    map.landmarks.emplace_back(xy[0], xy[1]);
  }
  return map;
}

LandmarkMap load_landmark_map(const std::string& file, size_t max_landmarks) {
  const Params params = Params::load_file(file);
  return parse_landmark_map(Params(params.node(), "map '" + file + "'"), max_landmarks);
}

std::string landmark_map_yaml(const LandmarkMap& map) {
  std::ostringstream out;
  out.precision(10);
  out << "frame_id: " << map.frame_id << "\nceiling_height: " << map.ceiling_height << "\nlandmarks:\n";
  for (const Eigen::Vector2d& p : map.landmarks) out << "  - [" << p.x() << ", " << p.y() << "]\n";
  return out.str();
}

// ------------------------------------------------------------------ NearestLandmarkIndex

namespace {
double distance_to_box(const Eigen::Vector2d& p, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  const double dx = std::max({lo.x() - p.x(), 0.0, p.x() - hi.x()});
  const double dy = std::max({lo.y() - p.y(), 0.0, p.y() - hi.y()});
  return std::hypot(dx, dy);
}
double farthest_in_box(const Eigen::Vector2d& p, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  const double dx = std::max(std::abs(p.x() - lo.x()), std::abs(p.x() - hi.x()));
  const double dy = std::max(std::abs(p.y() - lo.y()), std::abs(p.y() - hi.y()));
  return std::hypot(dx, dy);
}
}  // namespace

NearestLandmarkIndex::NearestLandmarkIndex(std::vector<Eigen::Vector2d> landmarks, int k, double cell_size,
                                           double margin, size_t max_cells)
    : landmarks_(std::move(landmarks)), k_(k), cell_size_(cell_size) {
  if (landmarks_.empty()) throw ConfigError("landmark map is empty");
  if (k_ < 1 || k_ > kMaxCandidates) {
    throw ConfigError("nearest landmark index: k = " + std::to_string(k_) + " is out of range; allowed: [1, " +
                      std::to_string(kMaxCandidates) + "]");
  }
  k_ = std::min<int>(k_, static_cast<int>(landmarks_.size()));
  all_.resize(landmarks_.size());
  std::iota(all_.begin(), all_.end(), 0);
  Eigen::AlignedBox2d box;
  for (const auto& p : landmarks_) box.extend(p);
  origin_ = box.min() - Eigen::Vector2d::Constant(margin);
  const Eigen::Vector2d extent = box.sizes() + Eigen::Vector2d::Constant(2.0 * margin);
  const double cols = std::ceil(extent.x() / cell_size_), rows = std::ceil(extent.y() / cell_size_);
  if (cols * rows > static_cast<double>(max_cells)) {
    throw ConfigError("landmark index needs " + std::to_string(static_cast<size_t>(cols * rows)) +
                      " cells (cell size " + std::to_string(cell_size_) + " m); allowed at most " +
                      std::to_string(max_cells) + " (limits.max_map_cells)");
  }
  columns_ = std::max(1, static_cast<int>(cols));
  rows_ = std::max(1, static_cast<int>(rows));

  // Coarse buckets to find, per cell, the landmarks that may be among its k nearest without a
  // scan of the whole map.
  const double bucket = std::max(cell_size_ * 8.0, 1e-3);
  const int bcols = std::max(1, static_cast<int>(std::ceil(extent.x() / bucket)));
  const int brows = std::max(1, static_cast<int>(std::ceil(extent.y() / bucket)));
  std::vector<std::vector<int>> buckets(static_cast<size_t>(bcols) * brows);
  auto bucket_of = [&](double v, double o, int n) {
    return std::clamp(static_cast<int>(std::floor((v - o) / bucket)), 0, n - 1);
  };
  for (int i = 0; i < static_cast<int>(landmarks_.size()); ++i) {
    const auto& p = landmarks_[i];
    buckets[bucket_of(p.y(), origin_.y(), brows) * bcols + bucket_of(p.x(), origin_.x(), bcols)].push_back(i);
  }

  cell_start_.assign(cells() + 1, 0);
  std::vector<double> farthest;
  std::vector<int> ring;
  for (int r = 0; r < rows_; ++r) {
    for (int c = 0; c < columns_; ++c) {
      const Eigen::Vector2d lo = origin_ + Eigen::Vector2d(c, r) * cell_size_;
      const Eigen::Vector2d hi = lo + Eigen::Vector2d::Constant(cell_size_);
      const int bc = bucket_of(0.5 * (lo.x() + hi.x()), origin_.x(), bcols);
      const int br = bucket_of(0.5 * (lo.y() + hi.y()), origin_.y(), brows);
      // Grow a square of buckets until it holds k landmarks; their k-th farthest distance D
      // bounds the search, then every landmark within D of the cell is a candidate.
      double bound = std::numeric_limits<double>::infinity();
      for (int radius = 0;; ++radius) {
        farthest.clear();
        for (int y = std::max(0, br - radius); y <= std::min(brows - 1, br + radius); ++y)
          for (int x = std::max(0, bc - radius); x <= std::min(bcols - 1, bc + radius); ++x)
            for (int i : buckets[y * bcols + x]) farthest.push_back(farthest_in_box(landmarks_[i], lo, hi));
        const bool covers_all = br - radius <= 0 && bc - radius <= 0 && br + radius >= brows - 1 &&
                                bc + radius >= bcols - 1;
        if (static_cast<int>(farthest.size()) >= k_) {
          std::nth_element(farthest.begin(), farthest.begin() + (k_ - 1), farthest.end());
          bound = farthest[k_ - 1];
          // Outside the square every landmark is at least radius * bucket - cell_size from the
          // cell (the cell may straddle its centre bucket's border), hence not a candidate.
          if (covers_all || bound <= radius * bucket - cell_size_) break;
        }
        if (covers_all) break;
      }
      ring.clear();
      const int reach = static_cast<int>(std::ceil(bound / bucket)) + 1;
      for (int y = std::max(0, br - reach); y <= std::min(brows - 1, br + reach); ++y)
        for (int x = std::max(0, bc - reach); x <= std::min(bcols - 1, bc + reach); ++x)
          for (int i : buckets[y * bcols + x])
            if (distance_to_box(landmarks_[i], lo, hi) <= bound) ring.push_back(i);
      candidates_.insert(candidates_.end(), ring.begin(), ring.end());
      cell_start_[static_cast<size_t>(r) * columns_ + c + 1] = static_cast<uint32_t>(candidates_.size());
    }
  }
}

int NearestLandmarkIndex::select(const Eigen::Vector2d& point, const int* candidates, int count,
                                 LandmarkCandidates& out) const {
  // Insertion into a sorted list of at most k (k is small).
  std::array<double, kMaxCandidates> best;
  const int k = k_;
  int n = 0;
  for (int i = 0; i < count; ++i) {
    const int id = candidates[i];
    const double d = (landmarks_[id] - point).squaredNorm();
    if (n == k && d >= best[n - 1]) continue;
    int j = (n < k) ? n++ : n - 1;
    while (j > 0 && best[j - 1] > d) {
      best[j] = best[j - 1];
      out[j] = out[j - 1];
      --j;
    }
    best[j] = d;
    out[j] = id;
  }
  return n;
}

int NearestLandmarkIndex::nearest(const Eigen::Vector2d& point, LandmarkCandidates& out) const {
  const double fc = std::floor((point.x() - origin_.x()) / cell_size_);
  const double fr = std::floor((point.y() - origin_.y()) / cell_size_);
  if (!(fc >= 0 && fr >= 0 && fc < columns_ && fr < rows_)) return nearest_brute_force(point, out);
  const size_t cell = static_cast<size_t>(fr) * columns_ + static_cast<size_t>(fc);
  const uint32_t begin = cell_start_[cell], end = cell_start_[cell + 1];
  return select(point, candidates_.data() + begin, static_cast<int>(end - begin), out);
}

int NearestLandmarkIndex::nearest_brute_force(const Eigen::Vector2d& point, LandmarkCandidates& out) const {
  return select(point, all_.data(), static_cast<int>(all_.size()), out);
}

double NearestLandmarkIndex::mean_candidates() const {
  return cells() ? static_cast<double>(candidates_.size()) / static_cast<double>(cells()) : 0.0;
}

}  // namespace locd::ceiling_pf
