// locsim's consistency and localization-state measures on synthetic estimate streams whose
// statistics are known: a consistent Gaussian stream gives NEES ~ chi-square(dof), an
// over-confident one is flagged, a state stream gives known delays and false alarms.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "locd/sim/consistency.hpp"
#include "locd/sim/evaluator.hpp"
#include "locd/sim/montecarlo.hpp"
#include "locd/sim/state_evaluation.hpp"

using locd::LocalizationState;
using locd::Pose2;
using locd::sim::ConsistencySample;
using locd::sim::StateSample;

namespace {

// A random covariance over (x, y, yaw): position stddevs 1 cm to 1 m along axes in a random
// orientation, heading 0.001 to 0.3 rad, correlated 0.3 with the first axis.
Eigen::Matrix3d random_covariance(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> log_sigma(std::log(0.01), std::log(1.0));
  std::uniform_real_distribution<double> log_heading(std::log(0.001), std::log(0.3));
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  const Eigen::Vector3d s(std::exp(log_sigma(rng)), std::exp(log_sigma(rng)), std::exp(log_heading(rng)));
  Eigen::Matrix3d D = s.cwiseProduct(s).asDiagonal();
  D(0, 2) = D(2, 0) = 0.3 * s.x() * s.z();
  Eigen::Matrix3d T = Eigen::Matrix3d::Identity();
  T.topLeftCorner<2, 2>() = Eigen::Rotation2Dd(angle(rng)).toRotationMatrix();
  return T * D * T.transpose();
}

// n estimates whose error is drawn from N(0, P_true) while the estimate reports scale * P_true.
std::vector<ConsistencySample> stream(size_t n, double reported_scale, LocalizationState state, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::vector<ConsistencySample> out;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Matrix3d P = random_covariance(rng);
    const Eigen::Matrix3d L = P.llt().matrixL();
    const Eigen::Vector3d e = L * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    const Pose2 truth(10.0 * normal(rng), 10.0 * normal(rng), locd::normalize_angle(3.0 * normal(rng)));
    const Pose2 estimate(truth.x + e.x(), truth.y + e.y(), locd::normalize_angle(truth.theta + e.z()));
    out.push_back({locd::sim::nees(estimate, truth, reported_scale * P), state});
  }
  return out;
}

}  // namespace

TEST(Consistency, BoundsAreTheChiSquareQuantiles) {
  const auto& b = locd::sim::ConsistencyBounds::get();
  EXPECT_NEAR(b.position_95, 5.9915, 1e-4);
  EXPECT_NEAR(b.position_99, 9.2103, 1e-4);
  EXPECT_NEAR(b.heading_95, 3.8415, 1e-4);
  EXPECT_NEAR(b.heading_99, 6.6349, 1e-4);
}

TEST(Consistency, NeesOfAKnownError) {
  Eigen::Matrix3d P = Eigen::Matrix3d::Zero();
  P.diagonal() << 0.04, 0.01, 0.0025;
  // 1 sigma in x, 1 sigma in y, 2 sigma in heading across the +-pi wrap.
  const auto n = locd::sim::nees({1.2, 2.1, M_PI - 0.05}, {1.0, 2.0, -M_PI + 0.05}, P);
  EXPECT_NEAR(n.position, 2.0, 1e-12);
  ASSERT_TRUE(n.heading);
  EXPECT_NEAR(*n.heading, 4.0, 1e-9);
  // Correlated: e^T P^-1 e by hand.
  P.topLeftCorner<2, 2>() << 0.05, 0.02, 0.02, 0.03;
  const Eigen::Vector2d e(0.1, -0.3);
  EXPECT_NEAR(locd::sim::nees({0.1, -0.3, 0}, {0, 0, 0}, P).position,
              e.dot(P.topLeftCorner<2, 2>().inverse() * e), 1e-12);
}

TEST(Consistency, SingularCovarianceAndNoHeadingVariance) {
  const Eigen::Matrix3d zero = Eigen::Matrix3d::Zero();
  const auto off = locd::sim::nees({0.1, 0, 0}, {0, 0, 0}, zero);
  EXPECT_TRUE(std::isinf(off.position));
  EXPECT_FALSE(off.heading);  // no heading variance: not estimated
  EXPECT_EQ(locd::sim::nees({0, 0, 0}, {0, 0, 0}, zero).position, 0.0);
  const auto summary = locd::sim::summarize_consistency({{off, LocalizationState::kTracking}});
  EXPECT_EQ(summary.outside_99_share, 1.0);
  EXPECT_EQ(summary.heading_samples, 0u);
  EXPECT_FALSE(summary.nees_heading_mean);
}

// A consistent stream: the NEES has the moments of chi-square (mean = dof, variance = 2 dof) and
// the shares inside the 95 % and outside the 99 % bounds are 95 % and 1 %.
TEST(Consistency, ConsistentGaussianStreamGivesNeesEqualToDof) {
  const size_t n = 40000;
  const auto samples = stream(n, 1.0, LocalizationState::kTracking, 11);
  double sum2 = 0.0;
  for (const auto& s : samples) sum2 += s.nees.position * s.nees.position;
  const auto c = locd::sim::summarize_consistency(samples);
  // Standard errors for n = 40000: mean 0.010 (2 dof), 0.007 (1 dof); share 95 %: 0.0011; 1 %: 0.0005.
  EXPECT_NEAR(c.nees_position_mean, 2.0, 0.05);
  EXPECT_NEAR(sum2 / n - c.nees_position_mean * c.nees_position_mean, 4.0, 0.3);  // variance 2 dof
  ASSERT_TRUE(c.nees_heading_mean);
  EXPECT_NEAR(*c.nees_heading_mean, 1.0, 0.035);
  EXPECT_NEAR(c.position_inside_95_share, 0.95, 0.006);
  EXPECT_NEAR(*c.heading_inside_95_share, 0.95, 0.006);
  EXPECT_NEAR(c.outside_99_share, 0.01, 0.0025);
  EXPECT_NEAR(c.heading_outside_99_share, 0.01, 0.0025);
  EXPECT_EQ(c.confidently_wrong_share, c.outside_99_share);  // tracking throughout
  EXPECT_EQ(c.verdict, "consistent");
}

// Reporting a quarter of the true covariance (half the sigma): NEES x 4, flagged.
TEST(Consistency, OverconfidentStreamIsFlagged) {
  const auto c = locd::sim::summarize_consistency(stream(20000, 0.25, LocalizationState::kTracking, 12));
  EXPECT_NEAR(c.nees_position_mean, 8.0, 0.3);
  EXPECT_NEAR(*c.nees_heading_mean, 4.0, 0.2);
  // P(chi2_2 > 9.21 / 4) = exp(-9.21 / 8) = 0.316.
  EXPECT_NEAR(c.outside_99_share, std::exp(-9.2103 / 8.0), 0.01);
  EXPECT_GT(c.confidently_wrong_share, 0.01);
  EXPECT_EQ(c.verdict, "overconfident");
  // A covariance 30 % too small in variance is at the verdict's edge; 50 % too small is past it.
  EXPECT_EQ(locd::sim::summarize_consistency(stream(20000, 0.5, LocalizationState::kTracking, 13)).verdict,
            "overconfident");
}

TEST(Consistency, ConservativeStreamIsNamed) {
  const auto c = locd::sim::summarize_consistency(stream(20000, 4.0, LocalizationState::kTracking, 14));
  EXPECT_NEAR(c.nees_position_mean, 0.5, 0.03);
  EXPECT_LT(c.outside_99_share, 0.001);
  EXPECT_EQ(c.verdict, "conservative");
}

// The same wrong estimates are not "confidently wrong" when the plugin said lost or uncertain.
TEST(Consistency, ConfidentlyWrongOnlyWhileTrackingOrUnknown) {
  for (auto state : {LocalizationState::kLost, LocalizationState::kUncertain}) {
    const auto c = locd::sim::summarize_consistency(stream(5000, 0.25, state, 15));
    EXPECT_GT(c.outside_99_share, 0.25);
    EXPECT_EQ(c.confidently_wrong_share, 0.0);
  }
  const auto unknown = locd::sim::summarize_consistency(stream(5000, 0.25, LocalizationState::kUnknown, 15));
  EXPECT_EQ(unknown.confidently_wrong_share, unknown.outside_99_share);
}

namespace {
// 10 s at 10 Hz: error 0.05 m, kidnapped at 3 s (error 8 m), relocalized at 6.5 s.
std::vector<StateSample> kidnap_states(double lost_from, double tracking_from, double false_alarm_at) {
  std::vector<StateSample> out;
  for (int i = 0; i < 100; ++i) {
    const double t = 0.1 * i;
    StateSample s{t, (t >= 3.0 && t < 6.5) ? 8.0 : 0.05, LocalizationState::kTracking};
    if (t >= lost_from && t < tracking_from) s.state = LocalizationState::kLost;
    if (std::abs(t - false_alarm_at) < 1e-9) s.state = LocalizationState::kUncertain;
    out.push_back(s);
  }
  return out;
}
}  // namespace

TEST(StateEvaluation, KidnapDelaysAndFalseAlarms) {
  // Lost from 4.2 s until 7.0 s: 0.5 s of "lost" after relocalization (6.5-6.9 s) are false alarms,
  // and one "uncertain" at 1.0 s.
  const auto s = locd::sim::evaluate_states(kidnap_states(4.2, 7.0, 1.0), {0.2, 3.0});
  EXPECT_EQ(s.samples, 100u);
  EXPECT_EQ(s.lost, 28u);
  EXPECT_EQ(s.uncertain, 1u);
  EXPECT_EQ(s.small_error_samples, 65u);
  EXPECT_EQ(s.false_alarms, 6u);
  EXPECT_NEAR(s.false_alarm_share, 6.0 / 65.0, 1e-12);
  ASSERT_TRUE(s.detection_delay_s);
  EXPECT_NEAR(*s.detection_delay_s, 1.2, 1e-9);  // not the false alarm before the kidnap
  ASSERT_TRUE(s.relocalization_delay_s);
  EXPECT_NEAR(*s.relocalization_delay_s, 3.5, 1e-9);
}

TEST(StateEvaluation, NeverDetectedNeverRelocalized) {
  std::vector<StateSample> samples;
  for (int i = 0; i < 50; ++i) samples.push_back({0.1 * i, i >= 10 ? 20.0 : 0.01, LocalizationState::kUnknown});
  const auto s = locd::sim::evaluate_states(samples, {0.2, 1.0});
  EXPECT_FALSE(s.detection_delay_s);
  EXPECT_FALSE(s.relocalization_delay_s);
  EXPECT_EQ(s.unknown, 50u);
  EXPECT_EQ(s.false_alarms, 0u);
  // Without an event there are no delays at all.
  const auto no_event = locd::sim::evaluate_states(samples, {0.2, std::nullopt});
  EXPECT_FALSE(no_event.event_s);
  EXPECT_FALSE(no_event.detection_delay_s);
}

// The evaluator carries covariance and state through to the summary.
TEST(TrajectoryEvaluator, ScoresNeesAndStates) {
  locd::sim::TrajectoryEvaluator evaluator(0.2, 1.0);
  locd::PoseEstimate estimate;
  estimate.covariance = locd::Matrix6d::Zero();
  estimate.covariance(0, 0) = estimate.covariance(1, 1) = 0.01;
  estimate.covariance(5, 5) = 0.0001;
  estimate.pose = Pose2(0.1, 0.1, 0.01).to_isometry();  // NEES 2 (position), 1 (heading)
  evaluator.add(0.0, estimate, {0, 0, 0}, LocalizationState::kTracking, 1.0);
  estimate.pose = Pose2(5.0, 0.0, 0.0).to_isometry();  // far outside
  evaluator.add(1.0, estimate, {0, 0, 0}, LocalizationState::kTracking, 1.0);
  evaluator.add(2.0, estimate, {0, 0, 0}, LocalizationState::kLost, 1.0);
  const auto s = evaluator.summary();
  EXPECT_NEAR(evaluator.estimates()[0].nees.position, 2.0, 1e-12);
  EXPECT_NEAR(*evaluator.estimates()[0].nees.heading, 1.0, 1e-12);
  EXPECT_NEAR(s.consistency.outside_99_share, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(s.consistency.confidently_wrong_share, 1.0 / 3.0, 1e-12);
  ASSERT_TRUE(s.localization.detection_delay_s);
  EXPECT_NEAR(*s.localization.detection_delay_s, 1.0, 1e-12);
}

// Pooling runs: rates over runs against the deadlines, shares over every estimate.
TEST(MonteCarlo, PoolsRunsAgainstTheDeadlines) {
  std::vector<locd::sim::RunResult> runs;
  const double detections[] = {1.0, 4.9, 9.0};  // the third misses the 5 s deadline
  for (int r = 0; r < 3; ++r) {
    locd::sim::TrajectoryEvaluator evaluator(0.2, 10.0);
    locd::PoseEstimate estimate;
    estimate.covariance = locd::Matrix6d::Identity() * 0.01;
    for (int i = 0; i < 300; ++i) {
      const double t = 0.1 * i;
      const bool wrong = t >= 10.0 && t < 10.0 + detections[r] + 2.0;
      estimate.pose = Pose2(wrong ? 5.0 : 0.0, 0.0, 0.0).to_isometry();
      const auto state = t >= 10.0 + detections[r] - 1e-9 && wrong ? LocalizationState::kLost : LocalizationState::kTracking;
      evaluator.add(t, estimate, {0, 0, 0}, state, 1.0);
    }
    locd::sim::RunResult result;
    result.seed = 1 + r;
    result.event = locd::sim::SimulatedEvent{"kidnap", 10.0, 5.0};
    result.summary = evaluator.summary();
    result.estimates = evaluator.estimates();
    runs.push_back(result);
  }
  const auto m = locd::sim::pool_runs("synthetic", "none", 1, {}, runs);
  EXPECT_EQ(m.runs.size(), 3u);
  EXPECT_EQ(m.detected, 2u);
  EXPECT_EQ(m.relocalized, 2u);  // error back under at 3.0, 6.9 and 11.0 s after the kidnap
  ASSERT_TRUE(m.detection_delay_max_s);
  EXPECT_NEAR(*m.detection_delay_max_s, 9.0, 1e-9);
  EXPECT_EQ(m.false_alarms, 0u);
  // Confidently wrong: the wrong estimates before each detection (10, 49, 90 of 900).
  EXPECT_NEAR(m.consistency.confidently_wrong_share, (10.0 + 49.0 + 90.0) / 900.0, 1e-9);
}
