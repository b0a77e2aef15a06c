#include <gtest/gtest.h>

#include "locd/sim/evaluator.hpp"

using locd::Pose2;
using locd::sim::TrajectoryEvaluator;

namespace {
// An estimate at `pose` with a unit covariance.
locd::PoseEstimate at(const Pose2& pose) {
  locd::PoseEstimate e;
  e.pose = pose.to_isometry();
  return e;
}
constexpr auto kUnknown = locd::LocalizationState::kUnknown;
}  // namespace

TEST(Percentile, LinearInterpolationBetweenRanks) {
  EXPECT_DOUBLE_EQ(locd::sim::percentile({1, 2, 3, 4, 5}, 50), 3.0);
  EXPECT_DOUBLE_EQ(locd::sim::percentile({5, 1, 4, 2, 3}, 95), 4.8);
  EXPECT_DOUBLE_EQ(locd::sim::percentile({10, 20}, 25), 12.5);
  EXPECT_DOUBLE_EQ(locd::sim::percentile({7}, 99), 7.0);
  EXPECT_TRUE(std::isnan(locd::sim::percentile({}, 50)));
}

TEST(TrajectoryEvaluator, KnownSequence) {
  TrajectoryEvaluator evaluator(0.2);
  const double errors[] = {0.5, 0.3, 0.1, 0.1, 0.1};
  const double update_ms[] = {1, 2, 3, 4, 5};
  for (int i = 0; i < 5; ++i) {
    // Error along a 3-4-5 direction so both coordinates matter; heading 0.1 rad off.
    const Pose2 truth(i, 2.0, 3.1);
    const Pose2 estimate(i + 0.6 * errors[i], 2.0 - 0.8 * errors[i], 3.1 + 0.1);
    evaluator.add(i * 1.0, at(estimate), truth, kUnknown, update_ms[i], 2.0 * update_ms[i]);
  }
  const auto s = evaluator.summary();
  EXPECT_EQ(s.updates, 5u);
  EXPECT_NEAR(s.mean_error_m, 0.22, 1e-12);
  EXPECT_NEAR(s.rmse_m, std::sqrt((0.25 + 0.09 + 3 * 0.01) / 5), 1e-12);
  EXPECT_NEAR(s.p95_error_m, 0.46, 1e-12);
  EXPECT_NEAR(s.max_error_m, 0.5, 1e-12);
  EXPECT_NEAR(s.final_error_m, 0.1, 1e-12);
  EXPECT_NEAR(s.mean_heading_error_deg, 0.1 * 180 / M_PI, 1e-9);  // wraps across +-pi
  EXPECT_NEAR(s.update_ms_p50, 3.0, 1e-12);
  EXPECT_NEAR(s.update_ms_p99, 4.96, 1e-12);
  EXPECT_TRUE(s.converged);
  ASSERT_TRUE(s.convergence_time_s);
  EXPECT_DOUBLE_EQ(*s.convergence_time_s, 2.0);
  ASSERT_TRUE(s.latency_ms_p50 && s.overhead_ms_p50);
  EXPECT_NEAR(*s.latency_ms_p50, 6.0, 1e-12);
  EXPECT_NEAR(*s.overhead_ms_p50, 3.0, 1e-12);
}

TEST(TrajectoryEvaluator, NotConvergedWhenTheLastErrorIsLarge) {
  TrajectoryEvaluator evaluator(0.2);
  evaluator.add(0, at({0.05, 0, 0}), {0, 0, 0}, kUnknown, 1);
  evaluator.add(1, at({1.25, 0, 0}), {1, 0, 0}, kUnknown, 1);
  const auto s = evaluator.summary();
  EXPECT_FALSE(s.converged);
  EXPECT_FALSE(s.convergence_time_s);
  EXPECT_FALSE(s.latency_ms_p50);
}

TEST(TrajectoryEvaluator, ConvergedFromTheFirstEstimate) {
  TrajectoryEvaluator evaluator(0.2);
  evaluator.add(0.5, at({0.05, 0, 0}), {0, 0, 0}, kUnknown, 1);
  evaluator.add(1.0, at({1.1, 0, 0}), {1, 0, 0}, kUnknown, 1);
  const auto s = evaluator.summary();
  EXPECT_TRUE(s.converged);
  EXPECT_DOUBLE_EQ(*s.convergence_time_s, 0.5);
}
