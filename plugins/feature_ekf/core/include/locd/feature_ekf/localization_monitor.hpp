// feature_ekf's judgement of itself (beyond the paper): the localization state from two windows
// of scans, the last lost_window_scans (a kidnap must show at once) and the last window_scans.
// In this order:
//
//   lost       over the short window, the scans' mean agreement with the map at the estimate
//              (scan_agreement.hpp) is below lost_agreement, or fewer than lost_association_share
//              of the features extracted were associated (at least min_window_features extracted)
//   uncertain  over the long window: agreement below min_agreement; association share below
//              min_association_share; the
//              innovations larger than the covariance explains: the window's NIS sum (each
//              applied update 2 dof) above the chi-square quantile of nis_probability for 2 n dof;
//              or the largest position stddev above max_tracking_stddev
//   tracking   otherwise
//   lost       also after lost_after_uncertain_scans uncertain scans in a row: a filter that has
//              been unsure for a while is not trusted to find its way back alone (a corridor
//              that merely resembles the right one keeps it uncertain, never lost)
//
// A scan without a verdict on a criterion (no informative beams, no features) leaves that
// criterion to the others. The reason names the criterion and its value.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "locd/feature_ekf/config.hpp"
#include "locd/sdk/types.hpp"

namespace locd::feature_ekf {

// What one scan's update says about the estimate.
struct ScanStatistics {
  size_t extracted = 0;             // features extracted
  size_t associated = 0;            // of them, associated with the map (inside the gate)
  std::vector<double> nis;          // normalized innovation squared of each applied update (2 dof)
  std::optional<double> agreement;  // scan agreement at the updated estimate
  double position_stddev = 0.0;     // m, sqrt of the largest eigenvalue of the position covariance
};

// The window's statistics, also reported as diagnostics.
struct WindowStatistics {
  size_t scans = 0, extracted = 0, associated = 0, updates = 0;
  double nis_sum = 0.0;
  std::optional<double> mean_agreement;
  std::optional<double> association_share;  // none below min_window_features
  double nis_threshold = 0.0;               // chi-square quantile for 2 * updates dof
  double position_stddev = 0.0;             // of the latest scan
};

class LocalizationMonitor {
 public:
  explicit LocalizationMonitor(MonitorConfig config = {});

  // Adds a scan and judges the window.
  LocalizationAssessment add(const ScanStatistics& scan);
  void reset() {
    window_.clear();
    uncertain_in_a_row_ = 0;
  }
  // The last `scans` scans (all of the window by default).
  WindowStatistics statistics(size_t scans = SIZE_MAX) const;
  const MonitorConfig& config() const { return config_; }

 private:
  double nis_threshold(size_t dof) const;  // chi-square quantile of nis_probability, cached by dof

  LocalizationAssessment judge() const;  // the window's state, before the escalation

  MonitorConfig config_;
  std::deque<ScanStatistics> window_;
  int uncertain_in_a_row_ = 0;
  mutable std::vector<double> thresholds_;
};

}  // namespace locd::feature_ekf
