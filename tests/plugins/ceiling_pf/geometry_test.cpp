// Camera geometry (paper eq. 1-3), the k-nearest landmark index against a brute-force scan, and
// the velocity motion model (Table 2) against its direct formula.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "locd/ceiling_pf/ceiling_camera.hpp"
#include "locd/ceiling_pf/landmark_map.hpp"
#include "locd/ceiling_pf/velocity_motion_model.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sim_ceiling_pf/ceiling_world.hpp"

using namespace locd;
using namespace locd::ceiling_pf;

namespace {
CeilingCamera hall_camera(CameraMounting mounting = {}) {
  CameraIntrinsics in;  // 640 x 480, f = 240, centre (319.5, 239.5)
  return CeilingCamera(in, mounting, 2.42);
}
}  // namespace

TEST(CeilingPfCamera, PrincipalPointLooksStraightUp) {
  const CeilingCamera camera = hall_camera();
  const CeilingRay r = camera.ray(319.5, 239.5);
  EXPECT_NEAR(r.slant_range, 2.42 - 0.32, 1e-12);  // eq. (1): P = f h / f
  EXPECT_NEAR(r.elevation, M_PI / 2, 1e-12);       // eq. (3)
  EXPECT_NEAR(r.horizontal_range(), 0.0, 1e-12);
}

TEST(CeilingPfCamera, EquationsOneToThreeByHand) {
  const CeilingCamera camera = hall_camera();
  const double h = 2.1;
  // u = f, v = 0: 45 degrees elevation, to the robot's left (+y).
  CeilingRay r = camera.ray(319.5 + 240.0, 239.5);
  EXPECT_NEAR(r.slant_range, std::sqrt(2.0) * h, 1e-12);
  EXPECT_NEAR(r.azimuth, M_PI / 2, 1e-12);
  EXPECT_NEAR(r.elevation, M_PI / 4, 1e-12);
  EXPECT_NEAR(r.horizontal_range(), h, 1e-12);
  // u = 0, v = -f/2 (image top): straight ahead, range h/2.
  r = camera.ray(319.5, 239.5 - 120.0);
  EXPECT_NEAR(r.azimuth, 0.0, 1e-12);
  EXPECT_NEAR(r.slant_range, std::sqrt(1.25) * h, 1e-12);
  EXPECT_NEAR(r.elevation, std::atan2(1.0, 0.5), 1e-12);
  const Eigen::Vector2d p = camera.ceiling_point_in_base(319.5, 239.5 - 120.0);
  EXPECT_NEAR(p.x(), h / 2, 1e-12);
  EXPECT_NEAR(p.y(), 0.0, 1e-12);
  // u = 3, v = 4 (pixels): P = sqrt(9 + 16 + 240^2) h / 240, theta = atan2(3, -4).
  r = camera.ray(322.5, 243.5);
  EXPECT_NEAR(r.slant_range, std::sqrt(25.0 + 240.0 * 240.0) * h / 240.0, 1e-12);
  EXPECT_NEAR(r.azimuth, std::atan2(3.0, -4.0), 1e-12);
  EXPECT_NEAR(r.elevation, std::atan2(240.0, 5.0), 1e-12);
}

TEST(CeilingPfCamera, ProjectInvertsBackProjectionWithMounting) {
  const CeilingCamera camera = hall_camera({0.2, -0.1, 0.3, 0.4});
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> col(0, 640), row(0, 480);
  for (int i = 0; i < 200; ++i) {
    const double c = col(rng), r = row(rng);
    const Eigen::Vector2d p = camera.ceiling_point_in_base(c, r);
    const Eigen::Vector2d back = camera.project(p);
    EXPECT_NEAR(back.x(), c, 1e-9);
    EXPECT_NEAR(back.y(), r, 1e-9);
  }
}

TEST(CeilingPfCamera, AgreesWithTheSimulatorsIndependentProjection) {
  sim::ceiling::CeilingWorldConfig wc;
  wc.distractors = 0;
  const sim::ceiling::CeilingWorld world(wc);
  sim::ceiling::CeilingCameraConfig cc;
  cc.mount = Pose2(0.15, 0.05, -0.2);
  cc.noise_stddev = 0.0;
  const sim::ceiling::CeilingCameraRenderer renderer(cc, world);
  const CeilingCamera camera(CameraIntrinsics{}, CameraMounting{0.15, 0.05, -0.2, 0.32}, wc.ceiling_height);
  const Pose2 robot(40.0, 20.0, 0.7);
  int checked = 0;
  for (const auto& v : renderer.visible(robot)) {
    const Eigen::Vector2d p = camera.ceiling_point_in_base(v.pixel.x(), v.pixel.y());
    EXPECT_NEAR((p - v.in_base).norm(), 0.0, 1e-9);
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

TEST(CeilingPfCamera, RejectsCeilingBelowLens) {
  EXPECT_THROW(CeilingCamera(CameraIntrinsics{}, CameraMounting{0, 0, 0, 3.0}, 2.42), ConfigError);
}

class CeilingPfNearestLandmarkIndexTest : public ::testing::TestWithParam<std::tuple<std::string, int>> {};

TEST_P(CeilingPfNearestLandmarkIndexTest, MatchesBruteForce) {
  sim::ceiling::CeilingWorldConfig wc;
  wc.layout = std::get<0>(GetParam());
  wc.size = Eigen::Vector2d(30, 20);
  wc.columns = 8;
  wc.rows = 5;
  wc.count = 40;
  const sim::ceiling::CeilingWorld world(wc);
  const int k = std::get<1>(GetParam());
  const NearestLandmarkIndex index(world.landmarks(), k, 0.5, 4.0, 1'000'000);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> x(-8, 38), y(-8, 28);  // also outside the grid
  LandmarkCandidates fast, slow;
  for (int i = 0; i < 3000; ++i) {
    const Eigen::Vector2d p(x(rng), y(rng));
    const int n = index.nearest(p, fast);
    const int m = index.nearest_brute_force(p, slow);
    ASSERT_EQ(n, m);
    ASSERT_EQ(n, k);
    for (int j = 0; j < n; ++j) {
      // Same distances (ties may swap indices).
      EXPECT_NEAR((index.landmarks()[fast[j]] - p).norm(), (index.landmarks()[slow[j]] - p).norm(), 1e-12);
    }
  }
  EXPECT_LT(index.mean_candidates(), 6.0 * k + 10);  // short lists, not the whole map
}

INSTANTIATE_TEST_SUITE_P(Layouts, CeilingPfNearestLandmarkIndexTest,
                         ::testing::Combine(::testing::Values("grid", "jittered_grid", "random"),
                                            ::testing::Values(1, 3, 5)));

TEST(CeilingPfNearestLandmarkIndex, BoundsCellsBeforeAllocating) {
  const std::vector<Eigen::Vector2d> far{{0, 0}, {10000, 10000}};
  EXPECT_THROW(NearestLandmarkIndex(far, 3, 0.1, 1.0, 1'000'000), ConfigError);
}

TEST(CeilingPfLandmarkMap, ParsesAndRejectsMalformedEntries) {
  const LandmarkMap map = parse_landmark_map(
      Params::parse("ceiling_height: 2.42\nlandmarks: [[1, 2], [3.5, -4]]\n", "m"), 10);
  ASSERT_EQ(map.landmarks.size(), 2u);
  EXPECT_DOUBLE_EQ(map.landmarks[1].y(), -4.0);
  auto message = [](const std::string& text, size_t max = 10) {
    try {
      parse_landmark_map(Params::parse(text, "m"), max);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("ceiling_height: 2.42\nlandmarks: []\n").find("non-empty"), std::string::npos);
  EXPECT_NE(message("ceiling_height: 2.42\nlandmarks: [[1, 2], [x, 3]]\n").find("landmarks[1]"), std::string::npos);
  EXPECT_NE(message("ceiling_height: 2.42\nlandmarks: [[1, 2, 3]]\n").find("landmarks[0]"), std::string::npos);
  EXPECT_NE(message("ceiling_height: 2.42\nlandmarks: [[.nan, 2]]\n").find("finite"), std::string::npos);
  EXPECT_NE(message("landmarks: [[1, 2]]\n").find("ceiling_height"), std::string::npos);
  EXPECT_NE(message("ceiling_height: 2.42\nlandmarks: [[1, 2], [2, 3]]\n", 1).find("at most 1"), std::string::npos);
  EXPECT_NE(message("ceiling_height: 2.42\nlandmark: [[1, 2]]\n").find("landmark"), std::string::npos);
}

TEST(CeilingPfVelocityMotionModel, VelocityBetweenInvertsTheArc) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> v(-0.5, 0.5), w(-1.0, 1.0);
  for (int i = 0; i < 500; ++i) {
    const Pose2 from(1.0, 2.0, 0.3);
    const double lin = v(rng), ang = (i % 10 == 0) ? 0.0 : w(rng), dt = 0.05;
    const Pose2 to = VelocityMotionModel::move(from, lin, ang, 0.0, dt);
    const VelocityCommand u = velocity_between(from, to, dt);
    EXPECT_NEAR(u.linear, lin, 1e-9);
    EXPECT_NEAR(u.angular, ang, 1e-9);
  }
}

TEST(CeilingPfVelocityMotionModel, ArcMatchesSmallStepIntegration) {
  const Pose2 start(0.0, 0.0, 0.5);
  const double v = 0.4, w = 0.7, dt = 1.0;
  Pose2 p = start;
  const int steps = 100000;
  for (int i = 0; i < steps; ++i) {
    p.x += v * std::cos(p.theta) * dt / steps;
    p.y += v * std::sin(p.theta) * dt / steps;
    p.theta += w * dt / steps;
  }
  const Pose2 arc = VelocityMotionModel::move(start, v, w, 0.0, dt);
  EXPECT_NEAR(arc.x, p.x, 1e-5);
  EXPECT_NEAR(arc.y, p.y, 1e-5);
  EXPECT_NEAR(arc.theta, normalize_angle(p.theta), 1e-9);
}

TEST(CeilingPfVelocityMotionModel, SampleSpreadFollowsAlphas) {
  // Only alpha1 set: v is noisy with stddev alpha1 v^2, omega exact; so the travelled
  // distance has stddev alpha1 v^2 dt.
  const VelocityMotionModel model({0.3, 0.0, 0.0, 0.0, 0.0, 0.0});
  std::mt19937_64 rng(5);
  const VelocityCommand u{0.4, 0.0, 1.0};
  double sum = 0, sum2 = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const Pose2 p = model.sample(Pose2(), u, rng);
    EXPECT_NEAR(p.theta, 0.0, 1e-12);
    sum += p.x;
    sum2 += p.x * p.x;
  }
  const double mean = sum / n, stddev = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.4, 4 * 0.048 / std::sqrt(n));
  EXPECT_NEAR(stddev, 0.3 * 0.16, 0.002);
}
