// Relocalization when lost (beyond the paper): a global search of the feature map, tracked over
// the scans that follow, because one scan of a 180-degree laser often fits several places (a
// corridor seen from its west end looks like its north end turned by 90 degrees).
//
//   1. Hypotheses from line pairs. Two extracted lines that are not near parallel (at least
//      min_pair_angle apart) against every ordered pair of map walls that could be seen together
//      (not near parallel, segments within max_pair_distance): the heading that turns each
//      measured normal onto its wall's (either side of the wall) must agree within
//      angle_tolerance; the position then solves the two line equations. A corner is such a pair;
//      so is a side wall with a far end wall.
//   2. Both measured segments, placed by the hypothesis, must overlap their walls (as the
//      association's visibility test); hypotheses within 0.2 m and 0.05 rad are merged.
//   3. Each is cast against the scan (scan_agreement.hpp); the new_hypotheses that agree best
//      join the tracked set (unless within merge_distance and merge_angle of a tracked one), each
//      as an EKF of its own started with relocalized_stddev.
//   4. Every tracked hypothesis is the paper's filter on its own state: predicted by each odometry
//      message, corrected by each scan's features (FeatureEkfFilter::predict, correct), so it
//      does not drift away from where it is right. After the correction it is cast against the
//      scan (scan_agreement.hpp). Its evidence is the sum over scans of its disagreement (1 -
//      agreement): all tracked hypotheses are scored on the same scans, so the sums compare them
//      over everything seen since they were made; a door that one place has and the other lacks
//      counts for as long as it stays in view, and is not forgotten. A hypothesis is dropped when
//      its sum exceeds the best's by drop_disagreement, or its recent agreement (exponential
//      average, weight agreement_smoothing per scan) falls below drop_agreement; two that
//      converged to the same pose are one; at most max_tracked_hypotheses are kept, the best.
//      A new hypothesis starts at the best's sum plus birth_disagreement (it has not been tested
//      on what came before), and none are made while a hypothesis of min_hypothesis_scans scans
//      agrees accept_agreement: a place that merely looks like the right one now cannot reopen
//      what the scans before it settled.
//   5. The best (least summed disagreement) is accepted once it has been scored on
//      min_hypothesis_scans scans, its recent agreement reaches accept_agreement and every
//      distinct rival (farther than distinct_distance or distinct_angle) has summed
//      ambiguity_disagreement more: places that look alike stay rivals until the robot sees
//      what tells them apart.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "locd/feature_ekf/config.hpp"
#include "locd/feature_ekf/feature_ekf_filter.hpp"
#include "locd/feature_ekf/laser_feature_extractor.hpp"
#include "locd/feature_ekf/scan_agreement.hpp"
#include "locd/sdk/feature_map.hpp"
#include "locd/sdk/geometry.hpp"

namespace locd::feature_ekf {

struct PoseHypothesis {
  FeatureEkfFilter::Filter filter;  // its own EKF: state [x, y, theta] and covariance
  double disagreement = 0.0;        // summed 1 - agreement over the scans (births start above the best)
  double recent = 0.0;              // exponential average of its agreements
  int scans = 0;                    // scans it was scored on
  Pose2 pose() const { return Pose2::from_vector(filter.state()); }
};

struct GlobalSearchResult {
  std::optional<PoseHypothesis> accepted;
  size_t generated = 0;                   // new hypotheses on this scan (after visibility, merging)
  std::vector<PoseHypothesis> tracked;    // best score first
  std::string reason;                     // why accepted or not
};

class GlobalFeatureSearch {
 public:
  // Keeps references to the filter (its map, association, motion model and update) and the
  // agreement: they must outlive this object. Throws ConfigError when the map has more than
  // max_map_pairs wall pairs.
  GlobalFeatureSearch(GlobalSearchConfig config, const FeatureEkfFilter& filter, const ScanAgreement& agreement);

  // Forgets every tracked hypothesis (a new search).
  void reset() { tracked_.clear(); }
  // Predicts every tracked hypothesis with an odometry control.
  void predict(const MotionControl& u);
  // Steps 3-5 on one scan; generate: also steps 1-2 from its features.
  GlobalSearchResult update(const ExtractedFeatures& features, const LaserScan& scan, bool generate);
  // Steps 1 and 2 alone (tests).
  std::vector<Pose2> hypotheses(const ExtractedFeatures& features) const;

  const std::vector<PoseHypothesis>& tracked() const { return tracked_; }
  size_t map_pairs() const { return map_pairs_.size(); }
  const GlobalSearchConfig& config() const { return config_; }

 private:
  // True when a hypothesis of `set` is within merge_distance and merge_angle of pose.
  bool near_any(const std::vector<PoseHypothesis>& set, const Pose2& pose) const;

  GlobalSearchConfig config_;
  const FeatureEkfFilter& ekf_;
  const FeatureMap2D& map_;
  const ScanAgreement& agreement_;
  std::vector<std::pair<int, int>> map_pairs_;  // ordered (a, b), a != b
  std::vector<PoseHypothesis> tracked_;
};

}  // namespace locd::feature_ekf
