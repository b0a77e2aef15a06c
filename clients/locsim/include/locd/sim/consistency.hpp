// Can a localizer's covariance be trusted? The normalized estimation error squared (NEES;
// Bar-Shalom, Li, Kirubarajan, "Estimation with Applications to Tracking and Navigation", 2001,
// sec. 5.4.2) of each estimate against the covariance the plugin reported with it:
//
//   position  e_xy^T P_xy^-1 e_xy          2 dof   (P_xy the x, y block of the pose covariance)
//   heading   e_yaw^2 / P_yaw,yaw          1 dof   (e_yaw wrapped to [-pi, pi))
//
// For a consistent estimator each is chi-square distributed with its dof: mean = dof, and the
// share of samples at or below the chi-square 95 % quantile (5.99 for 2 dof, 3.84 for 1 dof) is
// 95 %. The quantiles come from Boost.Math (locd::chi_square_quantile).
//
// "Outside the 99 % ellipse": position NEES above chi2_2(0.99) = 9.21, which a consistent
// estimator shows 1 % of the time. "Confidently wrong": outside the 99 % ellipse while the
// plugin said tracking, or said nothing (unknown): nothing warned the user. A plugin that says
// lost or uncertain is not confident.
//
// A plugin that reports no heading variance (0: it does not estimate heading, e.g. feature_ekf's
// landmark models) gets no heading NEES. A position block that is not positive definite gives an
// infinite NEES (outside every bound) unless the error is exactly zero.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/types.hpp"

namespace locd::sim {

// planar_covariance (locd/sdk/types.hpp): the (x, y, yaw) block of a pose covariance.

struct Nees {
  double position = 0.0;          // 2 dof
  std::optional<double> heading;  // 1 dof; none when the plugin reports no heading variance
};

Nees nees(const Pose2& estimate, const Pose2& truth, const Eigen::Matrix3d& covariance);

// Chi-square quantiles used for the bounds (Boost.Math), cached.
struct ConsistencyBounds {
  double position_95, position_99;  // 2 dof: 5.991, 9.210
  double heading_95, heading_99;    // 1 dof: 3.841, 6.635
  static const ConsistencyBounds& get();
};

struct ConsistencySample {
  Nees nees;
  LocalizationState state = LocalizationState::kUnknown;  // what the plugin said at the time
};

struct ConsistencySummary {
  size_t samples = 0;
  double nees_position_mean = 0.0;        // +inf when a position covariance was singular
  double position_inside_95_share = 0.0;  // NEES <= chi2_2(0.95); 0.95 when consistent
  size_t heading_samples = 0;             // estimates with a heading variance
  std::optional<double> nees_heading_mean;
  std::optional<double> heading_inside_95_share;
  double outside_99_share = 0.0;          // position error outside the 99 % ellipse
  double heading_outside_99_share = 0.0;  // heading error beyond chi2_1(0.99), of heading_samples
  double confidently_wrong_share = 0.0;   // outside the 99 % ellipse while tracking or unknown
  // "overconfident": fewer than 90 % of the position NEES inside their 95 % bound (a reported
  // covariance whose variances are about 30 % too small already gives 90 %); "conservative": a
  // mean position NEES below 1, half its dof (the covariance is on average more than twice the
  // error's); "consistent" otherwise; "none": no estimates. The verdict is about the covariance's
  // size; whether the plugin meets the target is the confidently-wrong share (<= 1 %).
  std::string verdict = "none";
};

ConsistencySummary summarize_consistency(const std::vector<ConsistencySample>& samples);

}  // namespace locd::sim
