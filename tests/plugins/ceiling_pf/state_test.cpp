// ceiling_pf's localization state (plugin/localizer.cpp), the plugin as loaded, in the paper's
// hall through locsim: tracking without false alarms, a kidnap reported as lost at once (w_fast
// against w_slow, the share of detections explained), then uncertain while the set is spread or
// multi-modal, tracking again once the filter has recovered.
#include <gtest/gtest.h>

#include "locd/sim/offline_runner.hpp"
#include "test_env.hpp"

using namespace locd;

namespace {
sim::RunResult hall_run(uint64_t seed, double duration_s, std::optional<double> kidnap_at) {
  sim::Scenario scenario = sim::load_scenario(test::source_dir() + "/config/scenarios/ceiling_hall.yaml");
  if (kidnap_at) scenario.kidnap = sim::KidnapSpec{*kidnap_at, std::nullopt, 10.0};
  sim::OfflineRunOptions options;
  options.plugin_directories = {test::plugin_dir()};
  options.seed = seed;
  options.duration_s = duration_s;
  return sim::run_offline(scenario, options);
}
}  // namespace

TEST(CeilingPfState, TracksThenReportsAKidnapAndRecovers) {
  const sim::RunResult plain = hall_run(3, 40.0, std::nullopt);
  ASSERT_GT(plain.summary.updates, 1000u);
  EXPECT_LT(plain.summary.localization.false_alarm_share, 0.01);
  EXPECT_GT(plain.summary.localization.tracking, plain.summary.updates * 95 / 100);
  EXPECT_LT(plain.summary.consistency.confidently_wrong_share, 0.01);

  // Seed 102: the filter recovers within seconds (augmented MCL), the state follows it.
  const sim::RunResult kidnap = hall_run(102, 60.0, 30.0);
  const sim::StateSummary& l = kidnap.summary.localization;
  ASSERT_TRUE(l.detection_delay_s);
  EXPECT_LT(*l.detection_delay_s, 1.0);
  EXPECT_GT(kidnap.summary.localization.lost, 0u);
  ASSERT_TRUE(l.relocalization_delay_s);
  EXPECT_LT(*l.relocalization_delay_s, 10.0);
  EXPECT_EQ(kidnap.estimates.back().state, LocalizationState::kTracking);
}
