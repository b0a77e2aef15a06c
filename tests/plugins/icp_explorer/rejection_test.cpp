// Each rejection rule of the modified ICP (paper section 2.1) on hand-made correspondences,
// each rule switched off, and the voxel preprocessing they work on.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "locd/icp_explorer/correspondence_rejection.hpp"
#include "locd/icp_explorer/scan_points.hpp"
#include "locd/sdk/geometry.hpp"

namespace ie = locd::icp_explorer;
using ie::Rejection;

namespace {

// Predicted pose: at (10, 5) facing +y; bounds 0.5 m forward, 0.2 m lateral, 0.05 m vertical,
// 10 deg yaw, no tilt, 0.1 m margin; scanner 1 m above base_link; range 20 m.
struct Fixture {
  ie::RejectionRules rules;
  ie::OdometryErrorBound bound;
  Eigen::Isometry3d predicted = locd::Pose2(10.0, 5.0, M_PI / 2).to_isometry();
  Eigen::Isometry3d sensor = Eigen::Isometry3d(Eigen::Translation3d(0, 0, 1.0));
  Fixture() {
    rules.intensity_threshold = 0.2;
    rules.max_range = 20.0;
    bound.forward = 0.5;
    bound.lateral = 0.2;
    bound.vertical = 0.05;
    bound.yaw = 10.0 * M_PI / 180;
    bound.tilt = 0.0;
    bound.margin = 0.1;
  }
  ie::CorrespondenceRejector rejector() const { return {rules, bound, predicted, sensor}; }
  // The model point at base-frame offset `error` from where odometry puts p.
  Eigen::Vector3d model_at(const Eigen::Vector3d& p, const Eigen::Vector3d& error) const {
    return predicted * (p + error);
  }
};

const float kNaN = std::numeric_limits<float>::quiet_NaN();

}  // namespace

TEST(RejectionRules, AcceptsAPairWithinEveryBound) {
  const Fixture f;
  const Eigen::Vector3d p(3.0, 0.0, 0.5);
  EXPECT_EQ(f.rejector().check(p, 0.5f, f.model_at(p, {0.3, 0.1, 0.02}), 0.55f), Rejection::kAccepted);
}

TEST(RejectionRules, IntensityRuleA) {
  Fixture f;
  const Eigen::Vector3d p(3.0, 0.0, 0.5);
  const Eigen::Vector3d q = f.model_at(p, {0.1, 0.0, 0.0});
  EXPECT_EQ(f.rejector().check(p, 0.2f, q, 0.45f), Rejection::kIntensity);
  EXPECT_EQ(f.rejector().check(p, 0.2f, q, 0.35f), Rejection::kAccepted);
  EXPECT_EQ(f.rejector().check(p, kNaN, q, 0.9f), Rejection::kAccepted) << "no intensity: rule (a) cannot judge";
  f.rules.intensity = false;
  EXPECT_EQ(f.rejector().check(p, 0.2f, q, 0.45f), Rejection::kAccepted);
  auto r = Fixture().rejector();
  r.disable_intensity();
  EXPECT_EQ(r.check(p, 0.2f, q, 0.45f), Rejection::kAccepted);
}

TEST(RejectionRules, OverlapRegionRuleB) {
  Fixture f;
  const auto r = f.rejector();
  // Scanner at (10, 5, 1); reach = 20 + |(0.5, 0.2, 0.05)| + 0.1 = 20.64 m.
  EXPECT_TRUE(r.in_overlap_region(Eigen::Vector3d(10.0 + 20.5, 5.0, 1.0)));
  EXPECT_FALSE(r.in_overlap_region(Eigen::Vector3d(10.0 + 20.8, 5.0, 1.0)));
  const Eigen::Vector3d p(3.0, 0.0, 0.0);
  f.rules.error_length = f.rules.error_direction = false;  // isolate rule (b)
  EXPECT_EQ(f.rejector().check(p, kNaN, Eigen::Vector3d(10.0, 5.0 + 25.0, 1.0), kNaN), Rejection::kOverlap);
  f.rules.overlap = false;
  EXPECT_EQ(f.rejector().check(p, kNaN, Eigen::Vector3d(10.0, 5.0 + 25.0, 1.0), kNaN), Rejection::kAccepted);
}

TEST(RejectionRules, ErrorLengthRuleC) {
  Fixture f;
  const auto r = f.rejector();
  const Eigen::Vector3d p(4.0, 3.0, 0.5);  // r_xy = 5 m
  const double chord = 2 * std::sin(5.0 * M_PI / 180) * 5.0;
  const double expected = std::sqrt(0.25 + 0.04 + 0.0025) + chord + 0.1;
  EXPECT_NEAR(r.max_error_length(p), expected, 1e-12);
  f.rules.error_direction = false;  // isolate rule (c)
  const Eigen::Vector3d along(0.6, 0.8, 0.0);  // unit
  EXPECT_EQ(f.rejector().check(p, kNaN, f.model_at(p, along * (expected + 0.05)), kNaN), Rejection::kErrorLength);
  EXPECT_EQ(f.rejector().check(p, kNaN, f.model_at(p, along * (expected - 0.05)), kNaN), Rejection::kAccepted);
  f.rules.error_length = false;
  EXPECT_EQ(f.rejector().check(p, kNaN, f.model_at(p, along * (expected + 0.05)), kNaN), Rejection::kAccepted);
}

TEST(RejectionRules, ErrorDirectionRuleD) {
  Fixture f;
  const Eigen::Vector3d p(1.0, 0.0, 0.0);  // 1 m ahead: the yaw arc is short (0.17 m, along y)
  const auto r = f.rejector();
  // Same length (0.45 m), different directions.
  EXPECT_TRUE(r.error_direction_possible(p, f.model_at(p, {0.45, 0.0, 0.0})));    // forward: within 0.5 + 0.1
  EXPECT_FALSE(r.error_direction_possible(p, f.model_at(p, {0.0, 0.0, 0.45})));   // up: vertical bound 0.15
  EXPECT_TRUE(r.error_direction_possible(p, f.model_at(p, {0.0, 0.45, 0.0})));    // lateral 0.3 + yaw arc 0.17
  EXPECT_FALSE(r.error_direction_possible(p, f.model_at(p, {0.0, -0.55, 0.0})));  // beyond lateral + arc
  // A point to the side: the yaw arc now runs along x, lateral stays tight.
  const Eigen::Vector3d side(0.0, 1.0, 0.0);
  EXPECT_FALSE(r.error_direction_possible(side, f.model_at(side, {0.0, 0.45, 0.0})));
  f.rules.error_length = false;  // isolate rule (d) in check()
  EXPECT_EQ(f.rejector().check(p, kNaN, f.model_at(p, {0.0, 0.0, 0.45}), kNaN), Rejection::kErrorDirection);
  f.rules.error_direction = false;
  EXPECT_EQ(f.rejector().check(p, kNaN, f.model_at(p, {0.0, 0.0, 0.45}), kNaN), Rejection::kAccepted);
}

TEST(RejectionRules, NamesForDiagnostics) {
  EXPECT_STREQ(ie::rejection_name(Rejection::kIntensity), "intensity");
  EXPECT_STREQ(ie::rejection_name(Rejection::kErrorDirection), "error_direction");
}

TEST(VoxelDownsample, CentroidsAndMeanIntensityPerVoxelSkippingNaN) {
  const std::vector<Eigen::Vector3f> points = {{0.1f, 0.1f, 0.1f}, {0.3f, 0.3f, 0.3f}, {1.2f, 0.1f, 0.1f},
                                               {NAN, 0.0f, 0.0f}};
  const std::vector<float> intensity = {0.2f, 0.4f, 0.9f, 0.5f};
  const auto out = ie::voxel_downsample(points, intensity, 1.0);
  ASSERT_EQ(out.size(), 2u);
  ASSERT_TRUE(out.has_intensity());
  EXPECT_TRUE(out.points[0].isApprox(Eigen::Vector3d(0.2, 0.2, 0.2), 1e-6));
  EXPECT_NEAR(out.intensity[0], 0.3f, 1e-6);
  EXPECT_NEAR(out.intensity[1], 0.9f, 1e-6);
  const auto without = ie::voxel_downsample(points, {}, 1.0);
  EXPECT_FALSE(without.has_intensity());
}
