// ceiling_pf's localization state (plugin/localizer.cpp), the plugin as loaded, in the paper's
// hall through locsim: tracking without false alarms, a kidnap reported as lost at once (w_fast
// against w_slow, the share of detections explained), then uncertain while the set is spread or
// multi-modal, tracking again once the filter has recovered.
#include <gtest/gtest.h>

#include "offline_run.hpp"

using namespace locd;


TEST(CeilingPfState, TracksThenReportsAKidnapAndRecovers) {
  const sim::RunResult plain = test::offline_run("ceiling_hall", 3, 40.0, std::nullopt);
  ASSERT_GT(plain.summary.updates, 1000u);
  EXPECT_LT(plain.summary.localization.false_alarm_share, 0.01);
  EXPECT_GT(plain.summary.localization.tracking, plain.summary.updates * 95 / 100);
  EXPECT_LT(plain.summary.consistency.confidently_wrong_share, 0.01);

  // Seed 102: the filter recovers within seconds (augmented MCL), the state follows it.
  const sim::RunResult kidnap = test::offline_run("ceiling_hall", 102, 60.0, 30.0);
  const sim::StateSummary& l = kidnap.summary.localization;
  ASSERT_TRUE(l.detection_delay_s);
  EXPECT_LT(*l.detection_delay_s, 1.0);
  EXPECT_GT(kidnap.summary.localization.lost, 0u);
  ASSERT_TRUE(l.relocalization_delay_s);
  EXPECT_LT(*l.relocalization_delay_s, 10.0);
  EXPECT_EQ(kidnap.estimates.back().state, LocalizationState::kTracking);
}
