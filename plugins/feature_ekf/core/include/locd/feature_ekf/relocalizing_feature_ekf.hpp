// The laser model as the plugin runs it: the paper's filter (FeatureEkfFilter), its judgement of
// itself (LocalizationMonitor, from the scan statistics and the scan's agreement with the map)
// and, when lost, relocalization by a global search of the feature map (GlobalFeatureSearch).
//
// With the search enabled (the default), lost is left only through the search (or a pose from
// outside). While lost the filter keeps running, a search runs at most every global_search.interval_s, and
// the pose is published with a covariance as wide as the map (uniform over its walls' bounding
// box, heading uniform): a consumer that reads only the covariance is not misled either. An
// accepted hypothesis hands its state and covariance to the filter; the state
// stays uncertain until a full window of scans after it has confirmed it.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>

#include "locd/feature_ekf/feature_ekf_filter.hpp"
#include "locd/feature_ekf/global_search.hpp"
#include "locd/feature_ekf/localization_monitor.hpp"
#include "locd/feature_ekf/scan_agreement.hpp"

namespace locd::feature_ekf {

struct ScanOutcome {
  ScanUpdateReport report;
  ScanStatistics statistics;
  WindowStatistics window;
  LocalizationAssessment localization;
  std::optional<GlobalSearchResult> search;  // while lost
  bool relocalized = false;
};

class RelocalizingFeatureEkf {
 public:
  RelocalizingFeatureEkf(FeatureEkfConfig config, FeatureMap2D map);
  RelocalizingFeatureEkf(const RelocalizingFeatureEkf&) = delete;  // its parts refer to each other
  RelocalizingFeatureEkf& operator=(const RelocalizingFeatureEkf&) = delete;

  // A pose from outside (initial pose, a switch of plugin): the filter restarts there and the
  // state is judged afresh.
  void set_pose(const Eigen::Vector3d& pose, const Eigen::Matrix3d& covariance);
  bool apply_odometry(const Pose2& odometry_pose, int64_t stamp_ns);
  ScanOutcome update(const LaserScan& scan);

  Eigen::Vector3d pose() const { return filter_.pose(); }
  // The filter's covariance, or while lost the map-wide one.
  Eigen::Matrix3d published_covariance() const;
  LocalizationState state() const { return state_; }
  const FeatureEkfFilter& filter() const { return filter_; }
  const GlobalFeatureSearch& global_search() const { return search_; }

 private:
  FeatureEkfFilter filter_;
  ScanAgreement agreement_;
  GlobalFeatureSearch search_;
  LocalizationMonitor monitor_;
  Eigen::Matrix3d lost_covariance_;
  LocalizationState state_ = LocalizationState::kUnknown;
  std::string lost_reason_;  // what made it lost
  std::optional<int64_t> last_generation_ns_;  // last new hypotheses while lost
  int confirming_scans_ = 0;  // scans left before a relocalization may say tracking
};

}  // namespace locd::feature_ekf
