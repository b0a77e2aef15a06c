#include "locd/feature_ekf/global_search.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>

#include "locd/sdk/errors.hpp"

namespace locd::feature_ekf {

namespace {

// Merge grid of new hypotheses.
constexpr double kMergePosition = 0.2, kMergeHeading = 0.05;

// Angle between two line directions (their normals), folded into [0, pi/2].
double line_angle(double a, double b) {
  const double d = std::abs(normalize_angle(a - b));
  return std::min(d, M_PI - d);
}

double segment_distance(const LineFeature& p, const LineFeature& q) {
  const auto point_to_segment = [](const Eigen::Vector2d& x, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const Eigen::Vector2d ab = b - a;
    const double t = std::clamp((x - a).dot(ab) / std::max(ab.squaredNorm(), 1e-12), 0.0, 1.0);
    return (a + t * ab - x).norm();
  };
  return std::min({point_to_segment(p.a, q.a, q.b), point_to_segment(p.b, q.a, q.b), point_to_segment(q.a, p.a, p.b),
                   point_to_segment(q.b, p.a, p.b)});
}

std::string number(double v, int digits = 2) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f", digits, v);
  return text;
}

}  // namespace

bool GlobalFeatureSearch::near_any(const std::vector<PoseHypothesis>& set, const Pose2& pose) const {
  return std::any_of(set.begin(), set.end(), [&](const PoseHypothesis& h) {
    const Pose2 p = h.pose();
    return std::hypot(p.x - pose.x, p.y - pose.y) <= config_.merge_distance &&
           std::abs(normalize_angle(p.theta - pose.theta)) <= config_.merge_angle;
  });
}

GlobalFeatureSearch::GlobalFeatureSearch(GlobalSearchConfig config, const FeatureEkfFilter& filter,
                                         const ScanAgreement& agreement)
    : config_(config), ekf_(filter), map_(filter.map()), agreement_(agreement) {
  if (!config_.enabled) return;
  for (size_t a = 0; a < map_.lines.size(); ++a) {
    for (size_t b = 0; b < map_.lines.size(); ++b) {
      if (a == b || line_angle(map_.lines[a].alpha(), map_.lines[b].alpha()) < config_.min_pair_angle) continue;
      if (segment_distance(map_.lines[a], map_.lines[b]) > config_.max_pair_distance) continue;
      if (map_pairs_.size() >= config_.max_map_pairs) {
        throw ConfigError("parameter 'feature_ekf.global_search.max_map_pairs' = " + std::to_string(config_.max_map_pairs) +
                          ": the map has more wall pairs within global_search.max_pair_distance (" +
                          number(config_.max_pair_distance, 1) +
                          " m) than that; raise it, lower max_pair_distance, or set global_search.enabled: false");
      }
      map_pairs_.emplace_back(static_cast<int>(a), static_cast<int>(b));
    }
  }
}

std::vector<Pose2> GlobalFeatureSearch::hypotheses(const ExtractedFeatures& features) const {
  std::map<std::tuple<long, long, long>, Pose2> merged;
  const auto& lines = features.lines;
  for (size_t i = 0; i < lines.size(); ++i) {
    for (size_t j = i + 1; j < lines.size(); ++j) {  // the map pairs are ordered both ways
      if (line_angle(lines[i].z.y(), lines[j].z.y()) < config_.min_pair_angle) continue;
      const double ri = lines[i].z.x(), phi_i = lines[i].z.y(), rj = lines[j].z.x(), phi_j = lines[j].z.y();
      for (const auto& [a, b] : map_pairs_) {
        const LineFeature& la = map_.lines[a];
        const LineFeature& lb = map_.lines[b];
        const double alpha_a = la.alpha(), alpha_b = lb.alpha();
        for (int flip_a = 0; flip_a < 2; ++flip_a) {
          for (int flip_b = 0; flip_b < 2; ++flip_b) {
            // phi = alpha - theta (+ pi when the robot is on the far side of the wall from the origin).
            const double theta_a = normalize_angle(alpha_a - phi_i + M_PI * flip_a);
            const double theta_b = normalize_angle(alpha_b - phi_j + M_PI * flip_b);
            const double difference = normalize_angle(theta_b - theta_a);
            if (std::abs(difference) > config_.angle_tolerance) continue;
            const double theta = normalize_angle(theta_a + 0.5 * difference);
            // x cos(alpha) + y sin(alpha) = rho - (+-) r for each wall.
            Eigen::Matrix2d A;
            A << std::cos(alpha_a), std::sin(alpha_a), std::cos(alpha_b), std::sin(alpha_b);
            const Eigen::Vector2d rhs(la.rho() - (flip_a ? -ri : ri), lb.rho() - (flip_b ? -rj : rj));
            const Eigen::Vector2d xy = A.partialPivLu().solve(rhs);
            if (!xy.allFinite()) continue;
            const Pose2 pose(xy.x(), xy.y(), theta);
            const Eigen::Vector3d v = pose.vector();
            const NearestNeighborAssociation& association = ekf_.association();
            if (!association.line_visible(lines[i], la, v) || !association.line_visible(lines[j], lb, v)) continue;
            const auto key = std::make_tuple(std::lround(pose.x / kMergePosition), std::lround(pose.y / kMergePosition),
                                             std::lround(pose.theta / kMergeHeading));
            merged.emplace(key, pose);
          }
        }
      }
    }
  }
  std::vector<Pose2> out;
  out.reserve(merged.size());
  for (const auto& [key, pose] : merged) out.push_back(pose);
  return out;
}

void GlobalFeatureSearch::predict(const MotionControl& u) {
  for (PoseHypothesis& h : tracked_) ekf_.predict(h.filter, u);
}

GlobalSearchResult GlobalFeatureSearch::update(const ExtractedFeatures& features, const LaserScan& scan, bool generate) {
  GlobalSearchResult result;
  // Tracked hypotheses: corrected by this scan, then scored on it (a scan without a verdict
  // leaves the scores).
  for (PoseHypothesis& h : tracked_) {
    ekf_.correct(h.filter, features);
    const std::optional<double> a = agreement_.agreement(scan, h.pose());
    if (!a) continue;
    h.disagreement += 1.0 - *a;
    h.recent = h.scans == 0 ? *a : (1.0 - config_.agreement_smoothing) * h.recent + config_.agreement_smoothing * *a;
    ++h.scans;
  }
  const auto by_evidence = [](const PoseHypothesis& p, const PoseHypothesis& q) { return p.disagreement < q.disagreement; };
  std::sort(tracked_.begin(), tracked_.end(), by_evidence);
  const bool settled = std::any_of(tracked_.begin(), tracked_.end(), [&](const PoseHypothesis& h) {
    return h.scans >= config_.min_hypothesis_scans && h.recent >= config_.accept_agreement;
  });
  if (generate && !settled) {
    const Eigen::Vector3d s0 = config_.relocalized_stddev;
    const Eigen::Matrix3d initial_covariance = s0.cwiseProduct(s0).asDiagonal();
    const double birth = tracked_.empty() ? 0.0 : tracked_.front().disagreement + config_.birth_disagreement;
    std::vector<PoseHypothesis> fresh;
    for (const Pose2& pose : hypotheses(features)) {
      PoseHypothesis h;
      h.filter.reset(pose.vector(), initial_covariance);
      h.disagreement = birth;
      h.recent = agreement_.agreement(scan, pose).value_or(0.0);
      fresh.push_back(h);
    }
    result.generated = fresh.size();
    const size_t keep = std::min(fresh.size(), config_.new_hypotheses);
    std::partial_sort(fresh.begin(), fresh.begin() + static_cast<long>(keep), fresh.end(),
                      [](const PoseHypothesis& p, const PoseHypothesis& q) { return p.recent > q.recent; });
    fresh.resize(keep);
    for (PoseHypothesis& h : fresh) {
      ekf_.correct(h.filter, features);
      if (near_any(tracked_, h.pose())) continue;
      if (const std::optional<double> a = agreement_.agreement(scan, h.pose())) {
        h.disagreement += 1.0 - *a;
        h.recent = *a;
        h.scans = 1;
      }
      tracked_.push_back(h);
    }
    std::sort(tracked_.begin(), tracked_.end(), by_evidence);
  }
  // Drop what the scans contradict; merge what converged; keep the best.
  if (!tracked_.empty()) {
    const double best_sum = tracked_.front().disagreement;
    std::vector<PoseHypothesis> kept;
    for (const PoseHypothesis& h : tracked_) {
      if (h.scans > 0 && h.recent < config_.drop_agreement) continue;
      if (h.disagreement > best_sum + config_.drop_disagreement) continue;
      if (near_any(kept, h.pose())) continue;
      kept.push_back(h);
    }
    tracked_ = std::move(kept);
  }
  if (tracked_.size() > config_.max_tracked_hypotheses) tracked_.resize(config_.max_tracked_hypotheses);
  result.tracked = tracked_;
  if (tracked_.empty()) {
    result.reason = "no hypothesis: " + std::to_string(features.lines.size()) +
                    " lines extracted, no pair of them matches a pair of walls";
    return result;
  }
  const PoseHypothesis& best = tracked_.front();
  if (best.recent < config_.accept_agreement || best.scans < config_.min_hypothesis_scans) {
    result.reason = "best of " + std::to_string(tracked_.size()) + " hypotheses agrees with the scans " +
                    number(100.0 * best.recent, 0) + " % over " + std::to_string(best.scans) + " scans; needs " +
                    number(100.0 * config_.accept_agreement, 0) + " % over " +
                    std::to_string(config_.min_hypothesis_scans);
    return result;
  }
  const Pose2 b = best.pose();
  for (size_t k = 1; k < tracked_.size(); ++k) {
    const PoseHypothesis& rival = tracked_[k];
    const Pose2 r = rival.pose();
    const bool distinct = std::hypot(r.x - b.x, r.y - b.y) > config_.distinct_distance ||
                          std::abs(normalize_angle(r.theta - b.theta)) > config_.distinct_angle;
    if (distinct && rival.disagreement < best.disagreement + config_.ambiguity_disagreement) {
      result.reason = "ambiguous: (" + number(b.x) + ", " + number(b.y) + ") and (" + number(r.x) + ", " + number(r.y) +
                      ") fit the scans alike (summed disagreement " + number(best.disagreement) + " and " +
                      number(rival.disagreement) + ")";
      return result;
    }
  }
  result.accepted = best;
  result.reason = "relocalized at (" + number(b.x) + ", " + number(b.y) + ", " + number(b.theta) + "): agrees " +
                  number(100.0 * best.recent, 0) + " % over " + std::to_string(best.scans) + " scans, the best of " +
                  std::to_string(tracked_.size()) + " hypotheses";
  tracked_.clear();
  return result;
}

}  // namespace locd::feature_ekf
