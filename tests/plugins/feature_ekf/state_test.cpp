// feature_ekf's judgement of itself and its relocalization: the scan's agreement with the map,
// the localization state from synthetic scan statistics, hypotheses from line pairs, and the
// whole plugin in the corridor through locsim with a kidnap and a wrong start.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "locd/feature_ekf/global_search.hpp"
#include "locd/feature_ekf/localization_monitor.hpp"
#include "locd/feature_ekf/relocalizing_feature_ekf.hpp"
#include "locd/feature_ekf/scan_agreement.hpp"
#include "offline_run.hpp"
#include "synthetic_scan.hpp"
#include "test_env.hpp"

using namespace locd;
using namespace locd::feature_ekf;

namespace {

FeatureMap2D corridor_map() {
  return load_feature_map(test::source_dir() + "/config/maps/corridor.yaml", 100000);
}

ScanStatistics good_scan() {
  ScanStatistics s;
  s.extracted = 4;
  s.associated = 4;
  s.nis = {1.5, 2.5, 2.0, 1.0};
  s.agreement = 0.98;
  s.position_stddev = 0.01;
  return s;
}

}  // namespace

TEST(ScanAgreement, HighAtTheTruePoseLowElsewhere) {
  const FeatureMap2D map = corridor_map();
  const ScanAgreement agreement(ScanAgreementConfig{}, map);
  std::mt19937_64 rng(3);
  for (const Pose2 truth : {Pose2(10.0, 1.0, 0.0), Pose2(39.0, 10.0, M_PI / 2), Pose2(38.5, 1.5, 0.8)}) {
    const LaserScan scan = test::ray_cast_scan(map.lines, truth, test::ScanGeometry{}, &rng);
    const auto at_truth = agreement.agreement(scan, truth);
    ASSERT_TRUE(at_truth);
    EXPECT_GE(*at_truth, 0.95) << truth.x << " " << truth.y;
    // Half a metre across the corridor, or 0.3 rad turned: most beams disagree.
    const auto beside = agreement.agreement(scan, Pose2(truth.x + 0.5 * std::sin(truth.theta),
                                                        truth.y - 0.5 * std::cos(truth.theta), truth.theta));
    const auto turned = agreement.agreement(scan, Pose2(truth.x, truth.y, truth.theta + 0.3));
    EXPECT_LT(beside.value_or(0.0), 0.6);
    EXPECT_LT(turned.value_or(0.0), 0.6);
  }
  // Nothing returned and no wall within range: no verdict.
  LaserScan empty = test::ray_cast_scan(map.lines, Pose2(10.0, 1.0, 0.0), test::ScanGeometry{});
  for (float& r : empty.ranges) r = std::numeric_limits<float>::infinity();
  FeatureMap2D no_walls;
  const ScanAgreement nothing(ScanAgreementConfig{}, no_walls);
  EXPECT_FALSE(nothing.agreement(empty, Pose2(10.0, 1.0, 0.0)));
  // The cast range is exact: 9 m from x = 31 to the corridor's end wall at x = 40.
  EXPECT_NEAR(agreement.cast({31.0, 1.0}, 0.0, 30.0), 9.0, 1e-9);
  EXPECT_TRUE(std::isinf(agreement.cast({31.0, 1.0}, 0.0, 5.0)));
}

TEST(ScanAgreement, CullingByRangeAndBearingGivesTheDirectCast) {
  // cast_all (walls culled by range and bearing) against cast (every wall tested): the same
  // range, bit for bit, on the corridor and on 300 random walls, from random origins, for random
  // headings and for the headings of the walls' ends (the edges of a bearing span).
  FeatureMap2D random_walls;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> coordinate(-20.0, 20.0), offset(-3.0, 3.0), angle(-M_PI, M_PI);
  for (int k = 0; k < 300; ++k) {
    LineFeature l;
    l.a = Eigen::Vector2d(coordinate(rng), coordinate(rng));
    l.b = l.a + Eigen::Vector2d(offset(rng), offset(rng));
    random_walls.lines.push_back(l);
  }
  size_t hits = 0, compared = 0;
  for (const FeatureMap2D& map : {corridor_map(), random_walls}) {
    const ScanAgreement agreement(ScanAgreementConfig{}, map);
    for (int trial = 0; trial < 40; ++trial) {
      const Eigen::Vector2d origin(coordinate(rng) + 20.0 * (map.lines.size() < 100), coordinate(rng) / 4.0 + 5.0);
      std::vector<double> headings;
      for (int k = 0; k < 200; ++k) headings.push_back(angle(rng) + 2.0 * M_PI * (k % 3 - 1));
      for (const LineFeature& l : map.lines) {
        headings.push_back(std::atan2(l.a.y() - origin.y(), l.a.x() - origin.x()));
        headings.push_back(std::atan2(l.b.y() - origin.y(), l.b.x() - origin.x()));
      }
      for (const double max_range : {3.0, 15.0, 80.0}) {
        const std::vector<double> fast = agreement.cast_all(origin, headings, max_range);
        ASSERT_EQ(fast.size(), headings.size());
        for (size_t k = 0; k < headings.size(); ++k) {
          const double direct = agreement.cast(origin, headings[k], max_range);
          ASSERT_EQ(fast[k], direct) << "origin " << origin.transpose() << " heading " << headings[k];
          hits += std::isfinite(direct);
          ++compared;
        }
      }
    }
  }
  EXPECT_GT(hits, compared / 4) << "the comparison must include many hits";
  EXPECT_LT(hits, compared) << "and misses";
}

TEST(ScanAgreement, Rep117ReadingsAreNoEvidence) {
  // Real lasers return NaN, zero, -inf (too close) and max-range readings where the map has a
  // wall: none of them may count as disagreement (issue 22: every 7th beam NaN sent the plugin to
  // lost). The agreement over the returns left is the same as without them.
  const FeatureMap2D map = corridor_map();
  const ScanAgreement agreement(ScanAgreementConfig{}, map);
  const Pose2 truth(10.0, 1.0, 0.0);
  std::mt19937_64 rng(5);
  const LaserScan scan = test::ray_cast_scan(map.lines, truth, test::ScanGeometry{}, &rng);
  const auto clean = agreement.agreement(scan, truth);
  ASSERT_TRUE(clean);
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(), 0.0f, -std::numeric_limits<float>::infinity(),
                       scan.range_max, std::numeric_limits<float>::infinity()};
  for (const float reading : bad) {
    LaserScan dropped = scan;
    for (size_t i = 0; i < dropped.ranges.size(); i += 7) dropped.ranges[i] = reading;
    const auto with_dropouts = agreement.agreement(dropped, truth);
    ASSERT_TRUE(with_dropouts) << reading;
    EXPECT_GE(*with_dropouts, 0.95) << "every 7th beam " << reading;
    EXPECT_NEAR(*with_dropouts, *clean, 0.05) << reading;
  }
}

TEST(LocalizationMonitor, TrackingOnGoodScans) {
  LocalizationMonitor monitor;
  LocalizationAssessment a;
  for (int i = 0; i < 30; ++i) a = monitor.add(good_scan());
  EXPECT_EQ(a.state, LocalizationState::kTracking) << a.reason;
  EXPECT_NE(a.reason.find("scan agrees 98.0 %"), std::string::npos) << a.reason;
  const WindowStatistics w = monitor.statistics();
  EXPECT_EQ(w.scans, 25u);
  EXPECT_EQ(w.updates, 100u);
  EXPECT_NEAR(w.nis_sum / static_cast<double>(w.updates), 1.75, 1e-12);
}

TEST(LocalizationMonitor, LostWithinTheShortWindow) {
  LocalizationMonitor monitor;
  for (int i = 0; i < 30; ++i) monitor.add(good_scan());
  ScanStatistics bad = good_scan();
  bad.agreement = 0.3;
  LocalizationAssessment a;
  int scans = 0;
  while (a.state != LocalizationState::kLost && scans < 10) {
    a = monitor.add(bad);
    ++scans;
  }
  // The mean over the last 5 scans falls below 75 % after 2 bad ones (0.98 * 3 + 0.3 * 2) / 5 = 0.708.
  EXPECT_EQ(scans, 2);
  EXPECT_NE(a.reason.find("scan agrees with the map"), std::string::npos) << a.reason;

  // Features that stop associating (no agreement verdict): lost below 20 %.
  LocalizationMonitor by_features;
  ScanStatistics unassociated = good_scan();
  unassociated.agreement.reset();
  unassociated.associated = 0;
  unassociated.nis.clear();
  for (int i = 0; i < 5; ++i) a = by_features.add(unassociated);
  EXPECT_EQ(a.state, LocalizationState::kLost);
  EXPECT_NE(a.reason.find("features associated 0.0 %"), std::string::npos) << a.reason;
}

TEST(LocalizationMonitor, UncertainCriteria) {
  // Innovations twice what the covariance explains: NIS mean 4 where 2 is expected.
  LocalizationMonitor nis;
  ScanStatistics s = good_scan();
  s.nis = {4.0, 4.0, 4.0, 4.0};
  LocalizationAssessment a;
  for (int i = 0; i < 25; ++i) a = nis.add(s);
  EXPECT_EQ(a.state, LocalizationState::kUncertain);
  EXPECT_NE(a.reason.find("NIS sum 400.0 >"), std::string::npos) << a.reason;
  EXPECT_NE(a.reason.find("200 dof"), std::string::npos) << a.reason;
  // Consistent innovations at the edge do not trip it: NIS mean 2.2 over 100 updates is inside
  // the 99.9 % quantile of chi-square(200) (about 267).
  LocalizationMonitor edge;
  s.nis = {2.2, 2.2, 2.2, 2.2};
  for (int i = 0; i < 25; ++i) a = edge.add(s);
  EXPECT_EQ(a.state, LocalizationState::kTracking) << a.reason;

  LocalizationMonitor wide;
  s = good_scan();
  s.position_stddev = 0.8;
  EXPECT_EQ(wide.add(s).state, LocalizationState::kUncertain);

  LocalizationMonitor half;
  s = good_scan();
  s.agreement = 0.85;  // above lost (75 %), below tracking (95 %)
  for (int i = 0; i < 5; ++i) a = half.add(s);
  EXPECT_EQ(a.state, LocalizationState::kUncertain);
  EXPECT_NE(a.reason.find("85.0 % < 95.0 %"), std::string::npos) << a.reason;
}

// Uncertain for lost_after_uncertain_scans scans in a row becomes lost (the search takes over).
TEST(LocalizationMonitor, LongUncertaintyBecomesLost) {
  MonitorConfig config;
  config.lost_after_uncertain_scans = 10;
  LocalizationMonitor monitor(config);
  ScanStatistics s = good_scan();
  s.agreement = 0.85;
  LocalizationAssessment a;
  for (int i = 0; i < 9; ++i) {
    a = monitor.add(s);
    EXPECT_EQ(a.state, LocalizationState::kUncertain) << i;
  }
  a = monitor.add(s);
  EXPECT_EQ(a.state, LocalizationState::kLost);
  EXPECT_NE(a.reason.find("uncertain for 10 scans in a row"), std::string::npos) << a.reason;
  // A tracking scan in between starts the count again.
  monitor.reset();
  for (int i = 0; i < 30; ++i) a = monitor.add(good_scan());
  for (int i = 0; i < 5; ++i) a = monitor.add(s);
  EXPECT_NE(a.state, LocalizationState::kLost);
}

// A robot at a corner of the corridor sees two walls at right angles: one of the hypotheses from
// its line pairs is where it is.
TEST(GlobalFeatureSearch, HypothesesIncludeTheTruePose) {
  const FeatureMap2D map = corridor_map();
  FeatureEkfConfig config;
  const FeatureEkfFilter filter(config, map);
  const ScanAgreement agreement(config.agreement, filter.map());
  const GlobalFeatureSearch search(config.global_search, filter, agreement);
  EXPECT_GT(search.map_pairs(), 100u);
  std::mt19937_64 rng(5);
  for (const Pose2 truth : {Pose2(36.0, 1.0, 0.0), Pose2(39.0, 15.0, M_PI / 2), Pose2(5.0, 19.0, M_PI)}) {
    const LaserScan scan = test::ray_cast_scan(map.lines, truth, test::ScanGeometry{}, &rng);
    const ExtractedFeatures features = filter.extractor().extract(scan);
    const std::vector<Pose2> hypotheses = search.hypotheses(features);
    double nearest = 1e9, heading = 0.0;  // the hypothesis nearest in position and heading (1 rad ~ 1 m)
    for (const Pose2& h : hypotheses) {
      const double d = std::hypot(h.x - truth.x, h.y - truth.y), a = std::abs(normalize_angle(h.theta - truth.theta));
      if (d + a < nearest + heading) {
        nearest = d;
        heading = a;
      }
    }
    EXPECT_LT(nearest, 0.1) << truth.x << " " << truth.y << " of " << hypotheses.size();
    EXPECT_LT(heading, 0.02);
  }
}

TEST(GlobalFeatureSearch, TooManyWallPairsIsAConfigError) {
  FeatureEkfConfig config;
  config.global_search.max_map_pairs = 10;
  const FeatureEkfFilter filter(config, corridor_map());
  const ScanAgreement agreement(config.agreement, filter.map());
  try {
    GlobalFeatureSearch search(config.global_search, filter, agreement);
    FAIL() << "accepted more pairs than max_map_pairs";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("global_search.max_map_pairs"), std::string::npos) << e.what();
  }
}

// While lost the pose goes out with a covariance as wide as the map.
TEST(RelocalizingFeatureEkf, LostPublishesAMapWideCovariance) {
  const FeatureMap2D map = corridor_map();
  RelocalizingFeatureEkf ekf(FeatureEkfConfig{}, map);
  ekf.set_pose({10.0, 1.0, 0.0}, Eigen::Vector3d(0.01, 0.01, 0.001).asDiagonal());
  // Scans taken in a room, (8, 4.5) facing north, while the filter believes it is in the corridor
  // at (10, 1) heading east. (Two stretches of corridor would not do: they look alike.)
  std::mt19937_64 rng(2);
  ScanOutcome out;
  for (int i = 0; i < 10 && ekf.state() != LocalizationState::kLost; ++i) {
    LaserScan scan = test::ray_cast_scan(map.lines, Pose2(8.0, 4.5, M_PI / 2), test::ScanGeometry{}, &rng);
    scan.header.stamp_ns = 1'000'000'000 + i * 40'000'000;
    out = ekf.update(scan);
  }
  ASSERT_EQ(ekf.state(), LocalizationState::kLost) << out.localization.reason;
  EXPECT_NEAR(ekf.published_covariance()(0, 0), 40.0 * 40.0 / 12.0, 1e-9);
  EXPECT_NEAR(ekf.published_covariance()(1, 1), 20.0 * 20.0 / 12.0, 1e-9);
  EXPECT_TRUE(out.search);
  // A new pose from outside ends it.
  ekf.set_pose({8.0, 4.5, M_PI / 2}, Eigen::Vector3d(0.01, 0.01, 0.001).asDiagonal());
  EXPECT_EQ(ekf.state(), LocalizationState::kUnknown);
  EXPECT_LT(ekf.published_covariance()(0, 0), 1.0);
}


// The plugin as loaded, in the corridor: tracking without false alarms, a kidnap reported at once
// and relocalized (seeds whose kidnap lands where the corridor is not symmetric), a wrong start
// reported and relocalized.
TEST(FeatureEkfRelocalization, CorridorKidnapAndWrongStart) {
  const sim::RunResult plain = test::offline_run("corridor", 11, 30.0, std::nullopt, std::nullopt);
  EXPECT_EQ(plain.summary.localization.false_alarms, 0u);
  EXPECT_EQ(plain.summary.localization.tracking, plain.summary.updates);
  EXPECT_LT(plain.summary.consistency.confidently_wrong_share, 0.01);

  for (uint64_t seed : {4u, 17u}) {
    const sim::RunResult kidnap = test::offline_run("corridor", seed, 60.0, 40.0, std::nullopt);
    ASSERT_TRUE(kidnap.event);
    EXPECT_GT(kidnap.event->distance_m, 10.0);
    const sim::StateSummary& l = kidnap.summary.localization;
    ASSERT_TRUE(l.detection_delay_s) << "seed " << seed;
    EXPECT_LT(*l.detection_delay_s, 1.0) << "seed " << seed;
    ASSERT_TRUE(l.relocalization_delay_s) << "seed " << seed;
    EXPECT_LT(*l.relocalization_delay_s, 10.0) << "seed " << seed;
    EXPECT_LT(kidnap.summary.final_error_m, 0.05) << "seed " << seed;
    EXPECT_EQ(kidnap.estimates.back().state, LocalizationState::kTracking) << "seed " << seed;
  }

  const sim::RunResult wrong = test::offline_run("corridor", 12, 30.0, std::nullopt, 15.0);
  ASSERT_TRUE(wrong.event);
  EXPECT_GT(wrong.event->distance_m, 15.0);
  ASSERT_TRUE(wrong.summary.localization.detection_delay_s);
  EXPECT_LT(*wrong.summary.localization.detection_delay_s, 5.0);
  ASSERT_TRUE(wrong.summary.localization.relocalization_delay_s);
  EXPECT_LT(wrong.summary.final_error_m, 0.05);
}
