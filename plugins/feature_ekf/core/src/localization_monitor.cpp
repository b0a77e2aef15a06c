#include "locd/feature_ekf/localization_monitor.hpp"

#include <algorithm>
#include <cstdio>

#include "locd/sdk/gaussian.hpp"

namespace locd::feature_ekf {

namespace {
std::string percent(double share) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f %%", 100.0 * share);
  return text;
}
std::string number(double v, int digits = 2) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f", digits, v);
  return text;
}
}  // namespace

LocalizationMonitor::LocalizationMonitor(MonitorConfig config) : config_(config) {}

double LocalizationMonitor::nis_threshold(size_t dof) const {
  if (thresholds_.size() <= dof) thresholds_.resize(dof + 1, 0.0);
  if (thresholds_[dof] == 0.0) thresholds_[dof] = chi_square_quantile(config_.nis_probability, static_cast<int>(dof));
  return thresholds_[dof];
}

WindowStatistics LocalizationMonitor::statistics(size_t scans) const {
  WindowStatistics w;
  w.scans = std::min(scans, window_.size());
  double agreement_sum = 0.0;
  size_t agreements = 0;
  for (auto it = window_.end() - static_cast<long>(w.scans); it != window_.end(); ++it) {
    const ScanStatistics& s = *it;
    w.extracted += s.extracted;
    w.associated += s.associated;
    w.updates += s.nis.size();
    for (double v : s.nis) w.nis_sum += v;
    if (s.agreement) {
      agreement_sum += *s.agreement;
      ++agreements;
    }
  }
  if (agreements) w.mean_agreement = agreement_sum / static_cast<double>(agreements);
  if (w.extracted >= static_cast<size_t>(config_.min_window_features)) {
    w.association_share = static_cast<double>(w.associated) / static_cast<double>(w.extracted);
  }
  if (w.updates) w.nis_threshold = nis_threshold(2 * w.updates);
  if (!window_.empty()) w.position_stddev = window_.back().position_stddev;
  return w;
}

LocalizationAssessment LocalizationMonitor::add(const ScanStatistics& scan) {
  window_.push_back(scan);
  while (window_.size() > static_cast<size_t>(config_.window_scans)) window_.pop_front();
  LocalizationAssessment a = judge();
  uncertain_in_a_row_ = a.state == LocalizationState::kUncertain ? uncertain_in_a_row_ + 1 : 0;
  if (config_.lost_after_uncertain_scans > 0 && uncertain_in_a_row_ >= config_.lost_after_uncertain_scans) {
    a = {LocalizationState::kLost,
         "uncertain for " + std::to_string(uncertain_in_a_row_) + " scans in a row: " + a.reason};
  }
  return a;
}

LocalizationAssessment LocalizationMonitor::judge() const {
  const WindowStatistics recent = statistics(static_cast<size_t>(config_.lost_window_scans));
  const std::string over_recent = " over the last " + std::to_string(recent.scans) + " scans";
  if (recent.mean_agreement && *recent.mean_agreement < config_.lost_agreement) {
    return {LocalizationState::kLost, "scan agrees with the map " + percent(*recent.mean_agreement) + " < " +
                                          percent(config_.lost_agreement) + over_recent};
  }
  if (recent.association_share && *recent.association_share < config_.lost_association_share) {
    return {LocalizationState::kLost, "features associated " + percent(*recent.association_share) + " < " +
                                          percent(config_.lost_association_share) + over_recent};
  }
  const WindowStatistics w = statistics();
  const std::string over = " over the last " + std::to_string(w.scans) + " scans";
  if (w.mean_agreement && *w.mean_agreement < config_.min_agreement) {
    return {LocalizationState::kUncertain, "scan agrees with the map " + percent(*w.mean_agreement) + " < " +
                                               percent(config_.min_agreement) + over};
  }
  if (w.association_share && *w.association_share < config_.min_association_share) {
    return {LocalizationState::kUncertain, "features associated " + percent(*w.association_share) + " < " +
                                               percent(config_.min_association_share) + over};
  }
  if (w.updates && w.nis_sum > w.nis_threshold) {
    return {LocalizationState::kUncertain, "innovations too large: NIS sum " + number(w.nis_sum, 1) + " > " +
                                               number(w.nis_threshold, 1) + " (chi-square, " +
                                               std::to_string(2 * w.updates) + " dof)" + over};
  }
  if (w.position_stddev > config_.max_tracking_stddev) {
    return {LocalizationState::kUncertain, "position stddev " + number(w.position_stddev) + " m > " +
                                               number(config_.max_tracking_stddev) + " m"};
  }
  std::string reason = "tracking:";
  if (w.mean_agreement) reason += " scan agrees " + percent(*w.mean_agreement) + ",";
  if (w.association_share) reason += " features associated " + percent(*w.association_share) + ",";
  reason += " NIS mean " + (w.updates ? number(w.nis_sum / static_cast<double>(w.updates)) : std::string("-")) + over;
  return {LocalizationState::kTracking, reason};
}

}  // namespace locd::feature_ekf
