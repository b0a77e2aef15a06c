// The localization state's criteria on synthetic beliefs (belief_assessment.hpp): modes against
// the blobs they were built from, entropy against its closed form, the peak mass and the disk
// maximum against brute force, each state from the criterion that decides it, and the reported
// covariance against the truth drawn from the belief (mean NEES = degrees of freedom).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "locd/emoi_markov/belief_assessment.hpp"
#include "locd/emoi_markov/markov_grid.hpp"

namespace {

using namespace locd::emoi;
using locd::GridGeometry;
using locd::LocalizationState;

GridGeometry geometry(int side, double resolution) {
  GridGeometry g;
  g.resolution = resolution;
  g.width = g.height = side;
  return g;
}

// Sum of isotropic Gaussian blobs (centre, stddev, mass), normalised to one.
struct Blob {
  Eigen::Vector2d centre;
  double stddev, mass;
};
cv::Mat_<float> blobs(const GridGeometry& g, const std::vector<Blob>& parts) {
  cv::Mat_<float> belief(g.height, g.width, 0.0f);
  for (const Blob& b : parts) {
    double total = 0.0;
    cv::Mat_<double> one(g.height, g.width, 0.0);
    for (int r = 0; r < g.height; ++r)
      for (int c = 0; c < g.width; ++c) {
        const double d2 = (g.center_of(r, c) - b.centre).squaredNorm();
        one(r, c) = std::exp(-0.5 * d2 / (b.stddev * b.stddev));
        total += one(r, c);
      }
    for (int r = 0; r < g.height; ++r)
      for (int c = 0; c < g.width; ++c) belief(r, c) += static_cast<float>(b.mass * one(r, c) / total);
  }
  belief /= cv::sum(belief)[0];
  return belief;
}

cv::Rect whole(const GridGeometry& g) { return cv::Rect(0, 0, g.width, g.height); }

TEST(BeliefModes, TwoBlobsAreTwoModesWithTheirMassesAndMoments) {
  const GridGeometry g = geometry(100, 1.0);
  const cv::Mat_<float> belief = blobs(g, {{{20.0, 30.0}, 2.0, 0.7}, {{70.0, 60.0}, 3.0, 0.3}});
  const auto modes = belief_modes(belief, g, 0.999, 0.01);
  ASSERT_EQ(modes.size(), 2u);
  EXPECT_NEAR(modes[0].mass, 0.7, 0.005);
  EXPECT_NEAR(modes[1].mass, 0.3, 0.005);
  EXPECT_NEAR(modes[0].mean.x(), 20.0, 0.05);
  EXPECT_NEAR(modes[0].mean.y(), 30.0, 0.05);
  EXPECT_NEAR(modes[1].mean.x(), 70.0, 0.05);
  // The region cuts the tails (0.1 %): the variance a little below the blob's, plus the cell's.
  EXPECT_NEAR(modes[0].covariance(0, 0), 4.0 + 1.0 / 12.0, 0.15);
  EXPECT_NEAR(modes[1].covariance(1, 1), 9.0 + 1.0 / 12.0, 0.3);
  EXPECT_NEAR(modes[0].covariance(0, 1), 0.0, 0.02);
}

TEST(BeliefModes, ASmallSecondBlobBelowMinModeMassIsNoMode) {
  const GridGeometry g = geometry(100, 1.0);
  const cv::Mat_<float> belief = blobs(g, {{{20.0, 30.0}, 2.0, 0.995}, {{70.0, 60.0}, 2.0, 0.005}});
  EXPECT_EQ(belief_modes(belief, g, 0.999, 0.01).size(), 1u);
  EXPECT_EQ(belief_modes(belief, g, 0.999, 0.001).size(), 2u);
}

TEST(BeliefEntropy, MatchesTheClosedForms) {
  const GridGeometry g = geometry(64, 1.0);
  cv::Mat_<float> uniform(g.height, g.width, 1.0f / (64.0f * 64.0f));
  EXPECT_NEAR(belief_entropy(uniform), std::log(64.0 * 64.0), 1e-4);
  cv::Mat_<float> point(g.height, g.width, 0.0f);
  point(10, 10) = 1.0f;
  EXPECT_NEAR(belief_entropy(point), 0.0, 1e-9);
  // A Gaussian of stddev s cells: ln(2 pi e s^2).
  const double s = 4.0;
  const cv::Mat_<float> gaussian = blobs(g, {{{32.0, 32.0}, s, 1.0}});
  EXPECT_NEAR(belief_entropy(gaussian), std::log(2.0 * M_PI * M_E * s * s), 0.01);
}

TEST(PeakMass, MassWithinAndTheDiskMaximumAgreeWithBruteForce) {
  const GridGeometry g = geometry(120, 0.1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  cv::Mat_<float> belief = blobs(g, {{{4.0, 5.0}, 0.6, 0.5}, {{7.5, 8.0}, 0.3, 0.3}, {{9.0, 3.0}, 1.5, 0.2}});
  for (auto& v : belief) v *= static_cast<float>(0.5 + unit(rng));  // rough, so the maximum is not obvious
  belief /= cv::sum(belief)[0];
  const double radius = 1.0;
  auto brute = [&](const Eigen::Vector2d& centre) {
    double held = 0.0;
    for (int r = 0; r < g.height; ++r)
      for (int c = 0; c < g.width; ++c)
        if ((g.center_of(r, c) - centre).squaredNorm() <= radius * radius * (1.0 + 1e-9)) held += belief(r, c);
    return held;
  };
  for (const Eigen::Vector2d& centre : {Eigen::Vector2d(4.05, 5.05), Eigen::Vector2d(0.05, 11.95), Eigen::Vector2d(7.5, 8.0)}) {
    EXPECT_NEAR(mass_within(belief, whole(g), g, centre, radius), brute(centre), 1e-5) << centre.transpose();
  }
  double best = 0.0;
  Eigen::Vector2d best_at = Eigen::Vector2d::Zero();
  for (int r = 0; r < g.height; ++r)
    for (int c = 0; c < g.width; ++c) {
      const double held = brute(g.center_of(r, c));
      if (held > best) {
        best = held;
        best_at = g.center_of(r, c);
      }
    }
  GridGeometry pooled_geometry;
  const cv::Mat_<float> pooled = pooled_mass(belief, whole(g), g, 10, pooled_geometry);
  EXPECT_NEAR(cv::sum(pooled)[0], 1.0, 1e-5);
  double mass = 0.0;
  const Eigen::Vector2d at = disk_maximum(belief, whole(g), g, pooled, pooled_geometry, radius, mass);
  EXPECT_NEAR(mass, best, 1e-5);
  EXPECT_NEAR(mass, brute(at), 1e-5);
  EXPECT_LT((at - best_at).norm(), 0.15) << at.transpose() << " vs " << best_at.transpose();
}

// Each state from the criterion that decides it.
TEST(BeliefAssessment, EachStateFromItsCriterion) {
  const GridGeometry g = geometry(400, 0.1);  // 40 x 40 m
  AssessmentConfig config;                    // tracking: 90 % within 1 m, lost above 1000 m^2
  // Lost: spread over more than lost_area_m2 (uniform: 1600 m^2).
  cv::Mat_<float> uniform(g.height, g.width, 1.0f / (400.0f * 400.0f));
  BeliefAssessment a = assess_belief(uniform, whole(g), g, config);
  EXPECT_EQ(a.localization.state, LocalizationState::kLost) << a.localization.reason;
  EXPECT_NEAR(a.area_m2, 1600.0, 1.0);
  EXPECT_NE(a.localization.reason.find("lost_area_m2"), std::string::npos) << a.localization.reason;
  config.lost_area_m2 = 2000.0;  // the same belief, a larger lost area: one flat mode, peak mass tiny
  EXPECT_EQ(assess_belief(uniform, whole(g), g, config).localization.state, LocalizationState::kUncertain);
  config = AssessmentConfig{};
  // Uncertain: two modes, each tight.
  a = assess_belief(blobs(g, {{{10.0, 10.0}, 0.2, 0.6}, {{30.0, 25.0}, 0.2, 0.4}}), whole(g), g, config);
  EXPECT_EQ(a.localization.state, LocalizationState::kUncertain);
  ASSERT_EQ(a.modes.size(), 2u);
  EXPECT_NE(a.localization.reason.find("2 modes"), std::string::npos) << a.localization.reason;
  EXPECT_LT((a.estimate - Eigen::Vector2d(10.0, 10.0)).norm(), 0.15);
  EXPECT_NEAR(a.peak_mass, 0.6, 0.01);
  // Uncertain: one mode, too wide for the tracking radius (1 - exp(-1 / (2 s^2)) = 0.39 for s = 1).
  a = assess_belief(blobs(g, {{{20.0, 20.0}, 1.0, 1.0}}), whole(g), g, config);
  EXPECT_EQ(a.localization.state, LocalizationState::kUncertain);
  EXPECT_EQ(a.modes.size(), 1u);
  EXPECT_NEAR(a.peak_mass, 1.0 - std::exp(-0.5), 0.03);
  EXPECT_NE(a.localization.reason.find("tracking_mass"), std::string::npos) << a.localization.reason;
  // Tracking: one mode, 0.3 m wide: 1 - exp(-1 / 0.18) = 0.996 within 1 m.
  a = assess_belief(blobs(g, {{{20.0, 20.0}, 0.3, 1.0}}), whole(g), g, config);
  EXPECT_EQ(a.localization.state, LocalizationState::kTracking) << a.localization.reason;
  EXPECT_GT(a.peak_mass, 0.99);
  EXPECT_LT(a.area_m2, 2.0 * M_PI * M_E);  // about 2 pi e s^2 (on 1 m cells: at least one cell)
  // A far second blob of 2 % makes the tight one uncertain.
  a = assess_belief(blobs(g, {{{20.0, 20.0}, 0.3, 0.98}, {{5.0, 35.0}, 0.3, 0.02}}), whole(g), g, config);
  EXPECT_EQ(a.localization.state, LocalizationState::kUncertain);
  EXPECT_EQ(a.modes.size(), 2u);
}

// The fit criterion: a tight single mode is tracking only once the local map has been checked
// against the DSM at the estimate and fits within max_fit_rms_m; it never lifts another state.
TEST(BeliefAssessment, TrackingNeedsTheLocalMapToFitAtTheEstimate) {
  const GridGeometry g = geometry(400, 0.1);
  const AssessmentConfig config;  // max_fit_rms_m 0.2
  const BeliefAssessment tight = assess_belief(blobs(g, {{{20.0, 20.0}, 0.3, 1.0}}), whole(g), g, config);
  ASSERT_EQ(tight.localization.state, LocalizationState::kTracking);
  BeliefAssessment a = tight;
  apply_fit(a, std::nan(""), config);
  EXPECT_EQ(a.localization.state, LocalizationState::kUncertain);
  EXPECT_NE(a.localization.reason.find("not yet checked"), std::string::npos) << a.localization.reason;
  a = tight;
  apply_fit(a, 0.5, config);
  EXPECT_EQ(a.localization.state, LocalizationState::kUncertain);
  EXPECT_NE(a.localization.reason.find("max_fit_rms_m"), std::string::npos) << a.localization.reason;
  EXPECT_DOUBLE_EQ(a.fit_rms_m, 0.5);
  a = tight;
  apply_fit(a, 0.05, config);
  EXPECT_EQ(a.localization.state, LocalizationState::kTracking);
  EXPECT_NE(a.localization.reason.find("fits to 0.05 m"), std::string::npos) << a.localization.reason;
  a = assess_belief(blobs(g, {{{20.0, 20.0}, 1.0, 1.0}}), whole(g), g, config);  // too wide
  apply_fit(a, 0.05, config);
  EXPECT_EQ(a.localization.state, LocalizationState::kUncertain);
}

// The belief's second moment about the estimate, as the filter reports it (summary covariance
// moved from the maximum cell to the estimate), is honest for a Gaussian belief: truths drawn
// from the belief give a mean NEES of 2 (2 dof) and 1 % outside the 99 % ellipse.
TEST(BeliefAssessment, CovarianceAboutTheEstimateGivesNeesOfTwo) {
  const GridGeometry g = geometry(300, 0.1);
  MarkovGrid grid(g, cv::Mat_<uchar>(300, 300, uchar(1)));
  const Eigen::Vector2d centre(15.0, 14.0);
  const double s = 1.2;
  grid.set_gaussian(centre, s);
  const BeliefSummary summary = grid.summary();
  const BeliefAssessment a = assess_belief(grid.belief(), grid.occupied(), g, AssessmentConfig{});
  const Eigen::Vector2d from_mode = summary.mean - summary.mode, from_estimate = summary.mean - a.estimate;
  const Eigen::Matrix2d P =
      summary.covariance - from_mode * from_mode.transpose() + from_estimate * from_estimate.transpose();
  std::mt19937 rng(17);
  std::normal_distribution<double> normal(0.0, s);
  const int draws = 20000;
  double nees = 0.0;
  int outside = 0;
  for (int i = 0; i < draws; ++i) {
    const Eigen::Vector2d truth = centre + Eigen::Vector2d(normal(rng), normal(rng));
    const Eigen::Vector2d e = a.estimate - truth;
    const double value = e.dot(P.ldlt().solve(e));
    nees += value;
    outside += value > 9.2103 ? 1 : 0;
  }
  EXPECT_NEAR(nees / draws, 2.0, 0.1);
  EXPECT_NEAR(static_cast<double>(outside) / draws, 0.01, 0.004);
}

}  // namespace
