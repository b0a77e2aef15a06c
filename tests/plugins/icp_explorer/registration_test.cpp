// The modified ICP recovers known transforms: on a synthetic cloud moved by a known transform,
// and scan-to-model in the toy world from odometry-like initial errors, for both metrics and
// with the rejection rules on and off, from 1 m / 10 degrees off with the coarse stage; when it
// says converged; its Jacobians and frames against finite differences and direct formulas.
#include <gtest/gtest.h>

#include <random>

#include "locd/icp_explorer/modified_icp.hpp"
#include "toy_world.hpp"

namespace ie = locd::icp_explorer;
using locd::Pose2;

namespace {

double translation_error(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}
double rotation_error_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

ie::RejectionRules rules(bool on) {
  ie::RejectionRules r;
  r.intensity = r.overlap = r.error_length = r.error_direction = on;
  r.max_range = 15.0;
  return r;
}

}  // namespace

TEST(Se3, ExponentialMatchesMatrixExponentialSeries) {
  ie::Vector6d xi;
  xi << 0.3, -0.2, 0.1, 0.2, -0.1, 0.4;
  Eigen::Matrix4d twist = Eigen::Matrix4d::Zero();
  twist.topLeftCorner<3, 3>() = ie::skew(xi.tail<3>());
  twist.topRightCorner<3, 1>() = xi.head<3>();
  Eigen::Matrix4d series = Eigen::Matrix4d::Identity(), term = Eigen::Matrix4d::Identity();
  for (int k = 1; k < 30; ++k) {
    term = term * twist / k;
    series += term;
  }
  EXPECT_LT((ie::se3_exp(xi).matrix() - series).norm(), 1e-12);
}

TEST(Jacobians, MatchFiniteDifferences) {
  const Eigen::Vector3d x(1.5, -0.7, 2.0), q(1.3, -0.5, 2.2);
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, 0.8, -0.5).normalized();
  const auto J_plane = ie::point_to_plane_jacobian(x, n);
  const auto J_point = ie::point_to_point_jacobian(x);
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    ie::Vector6d d = ie::Vector6d::Zero();
    d[k] = h;
    const Eigen::Vector3d plus = ie::se3_exp(d) * x, minus = ie::se3_exp(-d) * x;
    const double plane = (n.dot(plus - q) - n.dot(minus - q)) / (2 * h);
    const Eigen::Vector3d point = (plus - minus) / (2 * h);
    EXPECT_NEAR(J_plane(0, k), plane, 1e-7) << "column " << k;
    EXPECT_LT((J_point.col(k) - point).norm(), 1e-7) << "column " << k;
  }
}

struct Case {
  ie::IcpMetric metric;
  bool rules_on;
  double dx, dy, dyaw_deg;
};

class RecoversKnownTransform : public ::testing::TestWithParam<Case> {};

// Synthetic: the model is a scan in the map; the data are the same surfaces scanned again from a
// second pose, expressed in that pose's frame; start = truth moved by (dx, dy, dyaw).
TEST_P(RecoversKnownTransform, ScanToModel) {
  const Case c = GetParam();
  const auto world = locd::test::two_rooms();
  const locd::sim::Scanner3D scanner(locd::test::coarse_scanner());
  ie::VoxelMap model(0.1);
  const Eigen::Isometry3d model_pose = Pose2(2.5, 1.5, 0.0).to_isometry();
  model.insert(locd::test::scan_in_map(world, scanner, model_pose, 0.1, 1),
               (model_pose * scanner.sensor_in_base()).translation());
  const Eigen::Isometry3d truth = Pose2(3.3, 2.0, 0.35).to_isometry();
  const ie::ScanPoints data = locd::test::scan_in_map(world, scanner, truth, 0.25, 2);
  const ie::ScanPoints data_in_base = ie::transformed(data, truth.inverse());
  const Eigen::Isometry3d initial = truth * Pose2(c.dx, c.dy, c.dyaw_deg * M_PI / 180).to_isometry();
  ie::IcpSettings settings;
  settings.metric = c.metric;
  settings.max_iterations = 80;
  const ie::CorrespondenceRejector rejector(rules(c.rules_on), ie::OdometryErrorBound{}, initial,
                                            scanner.sensor_in_base());
  const ie::RegistrationResult r = ie::register_scan(data_in_base, model, initial, rejector, settings);
  EXPECT_TRUE(r.converged);
  // Point-to-plane meets the 2 cm / 0.2 deg on this coarse (1 deg) toy scan; point-to-point
  // slides along the sparse model surfaces and gets 3 cm / 0.4 deg.
  const bool plane = c.metric == ie::IcpMetric::kPointToPlane;
  EXPECT_LT(translation_error(r.T_map_base, truth), plane ? 0.02 : 0.03);
  EXPECT_LT(rotation_error_deg(r.T_map_base, truth), plane ? 0.2 : 0.4);
  EXPECT_GT(r.correspondences, data.size() / 2);
}

INSTANTIATE_TEST_SUITE_P(
    MetricsRulesAndStarts, RecoversKnownTransform,
    ::testing::Values(Case{ie::IcpMetric::kPointToPlane, true, 0.3, -0.2, 6.0},
                      Case{ie::IcpMetric::kPointToPlane, false, 0.3, -0.2, 6.0},
                      Case{ie::IcpMetric::kPointToPlane, true, -0.4, 0.25, -9.0},
                      Case{ie::IcpMetric::kPointToPoint, true, 0.3, -0.2, 6.0},
                      Case{ie::IcpMetric::kPointToPoint, true, -0.2, 0.2, -4.0}));

// The same cloud moved by a known 6-DoF transform (tilt included) is brought back exactly.
TEST(RecoversKnownTransform, SameCloudMovedRigidly) {
  const auto world = locd::test::two_rooms();
  const locd::sim::Scanner3D scanner(locd::test::coarse_scanner());
  const ie::ScanPoints cloud = locd::test::scan_in_map(world, scanner, Pose2(3.0, 2.0, 0.0).to_isometry(), 0.1, 3);
  ie::VoxelMap model(0.1);
  model.insert(cloud);
  const Eigen::Isometry3d moved = locd::isometry_from_xyz_rpy(0.15, -0.1, 0.03, 0.01, -0.015, 0.08);
  ie::IcpSettings settings;
  const ie::CorrespondenceRejector rejector(rules(false), ie::OdometryErrorBound{}, Eigen::Isometry3d::Identity(),
                                            Eigen::Isometry3d::Identity());
  const auto r = ie::register_scan(ie::transformed(cloud, moved), model, Eigen::Isometry3d::Identity(), rejector, settings);
  const Eigen::Isometry3d expected = moved.inverse();
  EXPECT_LT(translation_error(r.T_map_base, expected), 0.005);
  EXPECT_LT(rotation_error_deg(r.T_map_base, expected), 0.05);
}

TEST(Registration, EmptyModelOrScanReturnsTheStart) {
  ie::VoxelMap model(0.1);
  const Eigen::Isometry3d start = Pose2(1, 2, 0.3).to_isometry();
  const ie::CorrespondenceRejector rejector(rules(true), ie::OdometryErrorBound{}, start, Eigen::Isometry3d::Identity());
  const auto r = ie::register_scan(ie::ScanPoints{{Eigen::Vector3d(1, 0, 0)}, {}}, model, start, rejector, {});
  EXPECT_EQ(r.iterations, 0);
  EXPECT_FALSE(r.converged);
  EXPECT_TRUE(r.T_map_base.isApprox(start));
}

TEST(Se3, LogInvertsExpAndAdjointMovesAPerturbationAcross) {
  ie::Vector6d xi;
  xi << 0.3, -0.2, 0.1, 0.2, -0.1, 0.4;
  EXPECT_LT((ie::se3_log(ie::se3_exp(xi)) - xi).norm(), 1e-12);
  const Eigen::Isometry3d T = ie::se3_exp((ie::Vector6d() << 1.0, 2.0, -0.5, 0.1, 0.3, -0.7).finished());
  // exp(Ad_T xi) T = T exp(xi).
  const Eigen::Isometry3d left = ie::se3_exp(ie::se3_adjoint(T) * xi) * T, right = T * ie::se3_exp(xi);
  EXPECT_LT((left.matrix() - right.matrix()).norm(), 1e-12);
}

// |S omega|^2 is the mean squared motion of the points under a small rotation omega, and
// local_to_xi maps z = (motion at c, S omega) to the same rigid motion about the origin.
TEST(Jacobians, RotationScaleAndLocalFrameMatchTheDirectFormula) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Eigen::Vector3d> d;
  for (int i = 0; i < 200; ++i) d.emplace_back(8.0 * normal(rng), 2.0 * normal(rng), 0.5 * normal(rng));
  const Eigen::Matrix3d S = ie::rotation_scale(d);
  const Eigen::Vector3d omega(0.01, -0.02, 0.03);
  double mean = 0.0;
  for (const auto& p : d) mean += omega.cross(p).squaredNorm() / d.size();
  EXPECT_NEAR((S * omega).squaredNorm(), mean, 1e-12);
  const Eigen::Vector3d c(4.0, -3.0, 1.0), x(5.0, 2.0, 0.3);
  ie::Vector6d z;
  z << 0.1, -0.05, 0.02, 0.0, 0.0, 0.0;
  z.tail<3>() = S * omega;
  const ie::Vector6d xi = ie::local_to_xi(c, S) * z;
  // The motion of x: z.head at c plus omega x (x - c); xi gives v + omega x x.
  const Eigen::Vector3d direct = z.head<3>() + omega.cross(x - c);
  EXPECT_LT((xi.head<3>() + xi.tail<3>().cross(x) - direct).norm(), 1e-12);
}

// Robust from 1 m / 10 degrees: the toy world's scan registered from eight starts that far off
// (the odometry bound set to match), coarse stage first.
TEST(RecoversKnownTransform, FromOneMetreAndTenDegreesOffWithTheCoarseStage) {
  const auto world = locd::test::two_rooms();
  const locd::sim::Scanner3D scanner(locd::sim::Scanner3DConfig{});
  ie::VoxelMap model(0.1), coarse(ie::CoarseStageSettings{}.voxel_size);
  for (const Pose2& at : {Pose2(2.5, 1.5, 0.0), Pose2(8.0, 2.0, 3.0)}) {
    const Eigen::Isometry3d T = at.to_isometry();
    const ie::ScanPoints s = locd::test::scan_in_map(world, scanner, T, 0.1, 1);
    model.insert(s, (T * scanner.sensor_in_base()).translation());
    coarse.insert(s, (T * scanner.sensor_in_base()).translation());
  }
  const Eigen::Isometry3d truth = Pose2(3.3, 2.0, 0.35).to_isometry();
  const ie::ScanPoints data = ie::transformed(locd::test::scan_in_map(world, scanner, truth, 0.3, 2), truth.inverse());
  ie::OdometryErrorBound bound;
  bound.forward = bound.lateral = 1.0;
  bound.yaw = 10.0 * M_PI / 180;
  int within = 0;
  for (int k = 0; k < 8; ++k) {
    const double a = k * M_PI / 4, yaw = (k % 2 == 0 ? 1 : -1) * 10.0 * M_PI / 180;
    const Eigen::Isometry3d start = truth * Pose2(std::cos(a), std::sin(a), yaw).to_isometry();
    const ie::CorrespondenceRejector rejector(rules(true), bound, start, scanner.sensor_in_base());
    const ie::RegistrationResult r = ie::register_coarse_to_fine(data, model, &coarse, start, rejector, ie::IcpSettings{});
    const bool ok = translation_error(r.T_map_base, truth) < 0.02 && rotation_error_deg(r.T_map_base, truth) < 0.2;
    within += ok;
    EXPECT_TRUE(ok) << "start " << k << ": " << translation_error(r.T_map_base, truth) << " m, "
                    << rotation_error_deg(r.T_map_base, truth) << " deg; " << r.verdict;
    EXPECT_EQ(r.converged, ok) << "start " << k << ": " << r.verdict;
  }
  EXPECT_EQ(within, 8);
}

// `converged` only when the result can be trusted: not when the iterations ran out, and not when
// the scan does not fit the model where it ended (a robot 2.5 m from where odometry says).
TEST(Registration, ConvergedOnlyWhenTrustworthy) {
  const auto world = locd::test::two_rooms();
  const locd::sim::Scanner3D scanner(locd::test::coarse_scanner());
  ie::VoxelMap model(0.1);
  const Eigen::Isometry3d model_pose = Pose2(2.5, 1.5, 0.0).to_isometry();
  model.insert(locd::test::scan_in_map(world, scanner, model_pose, 0.1, 1),
               (model_pose * scanner.sensor_in_base()).translation());
  const Eigen::Isometry3d truth = Pose2(3.3, 2.0, 0.35).to_isometry();
  const ie::ScanPoints data = ie::transformed(locd::test::scan_in_map(world, scanner, truth, 0.25, 2), truth.inverse());
  const Eigen::Isometry3d start = truth * Pose2(0.3, -0.2, 6.0 * M_PI / 180).to_isometry();
  const ie::CorrespondenceRejector rejector(rules(true), ie::OdometryErrorBound{}, start, scanner.sensor_in_base());

  const ie::RegistrationResult good = ie::register_scan(data, model, start, rejector, ie::IcpSettings{});
  EXPECT_TRUE(good.converged) << good.verdict;
  EXPECT_TRUE(good.fits);
  EXPECT_GT(good.inlier_share, 0.8);
  EXPECT_EQ(good.stop, ie::IcpStop::kConverged);

  ie::IcpSettings two_iterations;
  two_iterations.max_iterations = 2;
  const ie::RegistrationResult cut = ie::register_scan(data, model, start, rejector, two_iterations);
  EXPECT_FALSE(cut.converged);
  EXPECT_EQ(cut.stop, ie::IcpStop::kIterationLimit);
  EXPECT_NE(cut.verdict.find("iteration limit"), std::string::npos) << cut.verdict;

  // Kidnapped: the robot stands at (6.8, 2.9) in the other room, odometry says the first room.
  const Eigen::Isometry3d elsewhere = Pose2(8.8, 2.9, -0.3).to_isometry();
  const ie::ScanPoints far_data =
      ie::transformed(locd::test::scan_in_map(world, scanner, elsewhere, 0.25, 3), elsewhere.inverse());
  const ie::RegistrationResult lost = ie::register_scan(far_data, model, start, rejector, ie::IcpSettings{});
  EXPECT_FALSE(lost.converged) << lost.verdict;
  EXPECT_GT(translation_error(lost.T_map_base, elsewhere), 1.0);
  // A scan of another building altogether does not fit at all.
  ie::VoxelMap other(0.1);
  std::vector<locd::sim::SurfaceBox> hall{{Eigen::AlignedBox3d(Eigen::Vector3d(-20, -20, -0.2), Eigen::Vector3d(20, 20, 0)), 0.5f, "floor"},
                                          {Eigen::AlignedBox3d(Eigen::Vector3d(1.0, -1.0, 0), Eigen::Vector3d(1.3, 1.0, 1.0)), 0.5f, "crate"},
                                          {Eigen::AlignedBox3d(Eigen::Vector3d(-2.0, 2.5, 0), Eigen::Vector3d(-1.0, 2.8, 2.0)), 0.5f, "crate"}};
  const locd::sim::IndoorWorld hall_world(std::move(hall), {});
  const ie::ScanPoints hall_data =
      ie::transformed(locd::test::scan_in_map(hall_world, scanner, truth, 0.25, 4), truth.inverse());
  const ie::RegistrationResult misfit = ie::register_scan(hall_data, model, start, rejector, ie::IcpSettings{});
  EXPECT_FALSE(misfit.fits) << misfit.verdict << ", inliers " << misfit.inlier_share;
  EXPECT_FALSE(misfit.converged) << misfit.verdict;
}
