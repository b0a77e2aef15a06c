// Motion and measurement models against central finite differences, the EKF update against the
// textbook formula, the chi-square gate against its quantile.
#include <gtest/gtest.h>

#include <random>

#include "locd/feature_ekf/extended_kalman_filter.hpp"
#include "locd/feature_ekf/feature_measurement_model.hpp"
#include "locd/feature_ekf/nearest_neighbor_association.hpp"
#include "locd/feature_ekf/odometry_motion_model.hpp"
#include "locd/sdk/gaussian.hpp"
#include "locd/sdk/geometry.hpp"

using namespace locd;
using namespace locd::feature_ekf;

namespace {

constexpr double kStep = 1e-6;

template <typename Function>
Eigen::MatrixXd numeric_jacobian(const Function& f, const Eigen::VectorXd& at, bool wrap_second_row) {
  const Eigen::VectorXd f0 = f(at);
  Eigen::MatrixXd J(f0.size(), at.size());
  for (int k = 0; k < at.size(); ++k) {
    Eigen::VectorXd plus = at, minus = at;
    plus[k] += kStep;
    minus[k] -= kStep;
    Eigen::VectorXd d = f(plus) - f(minus);
    for (int row = 0; row < d.size(); ++row) {
      if (wrap_second_row && row == d.size() - 1) d[row] = normalize_angle(d[row]);
    }
    J.col(k) = d / (2 * kStep);
  }
  return J;
}

const std::vector<Eigen::Vector3d> kPoses = {
    {0.0, 0.0, 0.0}, {1.5, -2.0, 0.7}, {-3.0, 4.0, 3.1}, {10.0, 2.5, -2.4}, {0.3, 0.2, -3.1}};

}  // namespace

TEST(OdometryMotionModel, StateJacobianMatchesFiniteDifferences) {
  for (const auto& x : kPoses) {
    for (const MotionControl u : {MotionControl{0.8, 0.05, 0.02}, MotionControl{-0.5, -0.3, 0.1},
                                  MotionControl{1.0, 0.0, 0.04}, MotionControl{0.0, 0.2, 0.02}}) {
      const auto f = [&](const Eigen::VectorXd& s) -> Eigen::VectorXd {
        return OdometryMotionModel::predict(Eigen::Vector3d(s), u);
      };
      const Eigen::MatrixXd numeric = numeric_jacobian(f, x, true);
      EXPECT_TRUE(OdometryMotionModel::jacobian_state(x, u).isApprox(numeric, 1e-6))
          << OdometryMotionModel::jacobian_state(x, u) << "\nvs\n" << numeric;
    }
  }
}

TEST(OdometryMotionModel, ControlJacobianMatchesFiniteDifferences) {
  for (const auto& x : kPoses) {
    for (const MotionControl u : {MotionControl{0.8, 0.05, 0.02}, MotionControl{-0.5, -0.3, 0.1},
                                  MotionControl{1.0, 0.0, 0.04}}) {
      const auto f = [&](const Eigen::VectorXd& c) -> Eigen::VectorXd {
        return OdometryMotionModel::predict(x, MotionControl{c[0], c[1], u.dt});
      };
      const Eigen::MatrixXd numeric = numeric_jacobian(f, Eigen::Vector2d(u.speed, u.turn), true);
      const Eigen::MatrixXd analytic = OdometryMotionModel::jacobian_control(x, u);
      EXPECT_LT((analytic - numeric).cwiseAbs().maxCoeff(), 1e-7) << analytic << "\nvs\n" << numeric;
    }
  }
}

TEST(OdometryMotionModel, ControlFromOdometryRecoversStraightAndReverseMotion) {
  const Pose2 start(2.0, 1.0, 0.6);
  const Pose2 forward = start * Pose2(0.04, 0.0, 0.0);
  MotionControl u = OdometryMotionModel::control_from_odometry(start, forward, 0.04);
  EXPECT_NEAR(u.speed, 1.0, 1e-9);
  EXPECT_NEAR(u.turn, 0.0, 1e-12);
  const Eigen::Vector3d predicted = OdometryMotionModel::predict(start.vector(), u);
  EXPECT_TRUE(predicted.isApprox(forward.vector(), 1e-12));

  const Pose2 backward = start * Pose2(-0.02, 0.0, 0.0);
  u = OdometryMotionModel::control_from_odometry(start, backward, 0.04);
  EXPECT_NEAR(u.speed, -0.5, 1e-9);

  const Pose2 turned = start * Pose2(0.0, 0.0, -0.3);
  u = OdometryMotionModel::control_from_odometry(start, turned, 0.1);
  EXPECT_NEAR(u.turn, -0.3, 1e-12);
  EXPECT_NEAR(u.speed, 0.0, 1e-12);
}

TEST(OdometryMotionModel, ControlNoiseGrowsWithMotion) {
  MotionNoiseConfig noise;
  noise.speed_stddev_per_speed = 0.1;
  noise.speed_stddev_floor = 0.02;
  noise.turn_stddev_per_turn = 0.2;
  noise.turn_stddev_per_distance = 0.05;
  noise.turn_stddev_floor = 0.001;
  const OdometryMotionModel model(noise);
  const MotionControl u{-2.0, 0.5, 0.1};
  const Eigen::Matrix2d Q = model.control_noise(u);
  EXPECT_NEAR(Q(0, 0), std::pow(0.1 * 2.0 + 0.02, 2), 1e-15);
  EXPECT_NEAR(Q(1, 1), std::pow(0.2 * 0.5 + 0.05 * 0.2 + 0.001, 2), 1e-15);
  EXPECT_EQ(Q(0, 1), 0.0);
  const Eigen::Matrix2d Q_still = model.control_noise({0.0, 0.0, 0.1});
  EXPECT_LT(Q_still(0, 0), Q(0, 0));
  EXPECT_LT(Q_still(1, 1), Q(1, 1));
}

TEST(FeatureMeasurementModel, LineJacobianMatchesFiniteDifferences) {
  for (const auto& x : kPoses) {
    for (const auto& [rho, alpha] : std::vector<std::pair<double, double>>{{5.0, 0.3}, {2.0, -2.0}, {0.5, 3.0}}) {
      const auto h = [&](const Eigen::VectorXd& s) -> Eigen::VectorXd {
        return FeatureMeasurementModel::predict_line(rho, alpha, Eigen::Vector3d(s));
      };
      MeasurementJacobian H;
      FeatureMeasurementModel::predict_line(rho, alpha, x, &H);
      const Eigen::MatrixXd numeric = numeric_jacobian(h, x, true);
      EXPECT_LT((H - numeric).cwiseAbs().maxCoeff(), 1e-6) << "rho " << rho << " alpha " << alpha << "\n"
                                                           << H << "\nvs\n" << numeric;
    }
  }
}

TEST(FeatureMeasurementModel, LineMeasurementIsTheLineSeenFromTheRobot) {
  // Wall y = 3 seen from (1, 1) heading 90 deg: straight ahead at 2 m; from (1, 5) it is behind.
  const LineFeature wall{"w", {-5, 3}, {5, 3}};
  Measurement2 z = FeatureMeasurementModel::predict_line(wall.rho(), wall.alpha(), {1.0, 1.0, M_PI / 2});
  EXPECT_NEAR(z.x(), 2.0, 1e-12);
  EXPECT_NEAR(z.y(), 0.0, 1e-12);
  z = FeatureMeasurementModel::predict_line(wall.rho(), wall.alpha(), {1.0, 5.0, M_PI / 2});
  EXPECT_NEAR(z.x(), 2.0, 1e-12);
  EXPECT_NEAR(std::abs(z.y()), M_PI, 1e-12);
}

TEST(FeatureMeasurementModel, PointJacobianMatchesFiniteDifferences) {
  for (const auto& x : kPoses) {
    for (const Eigen::Vector2d& p : {Eigen::Vector2d(4.0, 1.0), Eigen::Vector2d(-2.0, -7.0), Eigen::Vector2d(0.5, 9.0)}) {
      const auto h = [&](const Eigen::VectorXd& s) -> Eigen::VectorXd {
        return FeatureMeasurementModel::predict_point(p, Eigen::Vector3d(s));
      };
      MeasurementJacobian H;
      const Measurement2 z = FeatureMeasurementModel::predict_point(p, x, &H);
      EXPECT_NEAR(z.x(), (p - x.head<2>()).norm(), 1e-12);
      const Eigen::MatrixXd numeric = numeric_jacobian(h, x, true);
      EXPECT_LT((H - numeric).cwiseAbs().maxCoeff(), 1e-6) << H << "\nvs\n" << numeric;
    }
  }
}

TEST(FeatureMeasurementModel, InnovationWrapsTheAngle) {
  const Measurement2 v = FeatureMeasurementModel::innovation({2.0, 3.1}, {1.5, -3.1});
  EXPECT_NEAR(v.x(), 0.5, 1e-12);
  EXPECT_NEAR(v.y(), 6.2 - 2 * M_PI, 1e-12);
}

TEST(ChiSquareGating, ThresholdIsTheChiSquareQuantileForTwoDimensions) {
  const NearestNeighborAssociation association(AssociationConfig{0.99, 30.0, 0.3});
  const double threshold = association.gate().threshold(2);
  EXPECT_NEAR(threshold, chi_square_quantile(0.99, 2), 1e-9);
  EXPECT_NEAR(threshold, 9.2103, 1e-3);  // tabulated chi-square(2) 99 % point
  EXPECT_TRUE(association.gate().accepts(threshold * 0.999, 2));
  EXPECT_FALSE(association.gate().accepts(threshold * 1.001, 2));

  // An innovation just inside and just outside the gate, through the Mahalanobis distance.
  const Eigen::Matrix2d S = (Eigen::Matrix2d() << 0.04, 0.01, 0.01, 0.09).finished();
  const Eigen::Vector2d direction(0.6, -0.8);
  const double unit = squared_mahalanobis(direction, S);
  const double scale_at_gate = std::sqrt(threshold / unit);
  EXPECT_TRUE(association.gate().accepts(squared_mahalanobis(0.99 * scale_at_gate * direction, S), 2));
  EXPECT_FALSE(association.gate().accepts(squared_mahalanobis(1.01 * scale_at_gate * direction, S), 2));
}

TEST(ChiSquareGating, FixedSizeMahalanobisEqualsTheSdkOne) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    Eigen::Matrix2d A;
    A << n(rng), n(rng), n(rng), n(rng);
    const Eigen::Matrix2d S = A * A.transpose() + 0.01 * Eigen::Matrix2d::Identity();
    const Eigen::Vector2d v(n(rng), n(rng));
    EXPECT_NEAR(squared_mahalanobis(v, S), mahalanobis2(v, S), 1e-9 * (1 + mahalanobis2(v, S)));
  }
  EXPECT_TRUE(std::isinf(squared_mahalanobis(Eigen::Vector2d(1, 0), -Eigen::Matrix2d::Identity())));
}

TEST(ExtendedKalmanFilter, UpdateMatchesTheTextbookFormula) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::Matrix3d A = Eigen::Matrix3d::NullaryExpr([&] { return n(rng); });
    const Eigen::Matrix3d P = A * A.transpose() + 0.1 * Eigen::Matrix3d::Identity();
    const Eigen::Vector3d x(n(rng), n(rng), n(rng));
    const Eigen::Matrix<double, 2, 3> H = Eigen::Matrix<double, 2, 3>::NullaryExpr([&] { return n(rng); });
    const Eigen::Matrix2d R = (Eigen::Matrix2d() << 0.2, 0.05, 0.05, 0.1).finished();
    const Eigen::Vector2d v(n(rng), n(rng));

    ExtendedKalmanFilter<3> filter(x, P);
    ASSERT_TRUE(filter.update<2>(v, H, R));
    // Eq. 9, 13, 14 as printed.
    const Eigen::Matrix2d S = H * P * H.transpose() + R;
    const Eigen::Matrix<double, 3, 2> W = P * H.transpose() * S.inverse();
    EXPECT_TRUE(filter.state().isApprox(x + W * v, 1e-9));
    EXPECT_TRUE(filter.covariance().isApprox(P - W * S * W.transpose(), 1e-9));
  }
}

TEST(ExtendedKalmanFilter, PredictPropagatesCovarianceThroughBothJacobians) {
  const Eigen::Vector3d x(1.0, 2.0, 0.5);
  const Eigen::Matrix3d P = Eigen::Vector3d(0.01, 0.02, 0.003).asDiagonal();
  const MotionControl u{0.9, 0.1, 0.04};
  const OdometryMotionModel model;
  ExtendedKalmanFilter<3> filter(x, P);
  const Eigen::Matrix3d F = OdometryMotionModel::jacobian_state(x, u);
  const Eigen::Matrix<double, 3, 2> G = OdometryMotionModel::jacobian_control(x, u);
  filter.predict<2>(OdometryMotionModel::predict(x, u), F, G, model.control_noise(u));
  EXPECT_TRUE(filter.covariance().isApprox(F * P * F.transpose() + G * model.control_noise(u) * G.transpose(), 1e-12));
  EXPECT_TRUE(filter.state().isApprox(OdometryMotionModel::predict(x, u)));
}

TEST(ExtendedKalmanFilter, RejectsAnUpdateWhoseInnovationCovarianceIsNotPositiveDefinite) {
  ExtendedKalmanFilter<3> filter(Eigen::Vector3d::Zero(), Eigen::Matrix3d::Zero());
  const Eigen::Matrix<double, 2, 3> H = Eigen::Matrix<double, 2, 3>::Identity();
  EXPECT_FALSE(filter.update<2>(Eigen::Vector2d(1, 1), H, Eigen::Matrix2d::Zero()));
  EXPECT_EQ(filter.state(), Eigen::Vector3d::Zero());
}

namespace {

// A corridor: two long parallel walls 2 m apart and two collinear pieces of the south wall.
FeatureMap2D association_map() {
  FeatureMap2D map;
  map.lines.push_back({"south_a", {0, 0}, {10, 0}});
  map.lines.push_back({"south_b", {12, 0}, {20, 0}});
  map.lines.push_back({"north", {0, 2}, {20, 2}});
  map.corners.push_back({"c", {10, 2}});
  map.edges.push_back({"e", {10, 0}});
  return map;
}

ExtractedLine measured_line(const Pose2& robot, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Pose2 inverse = robot.inverse();
  const LineFeature in_robot{"", inverse.transform(a), inverse.transform(b)};
  ExtractedLine line;
  line.z = {in_robot.rho(), in_robot.alpha()};
  line.covariance = Eigen::Vector2d(0.02 * 0.02, 0.01 * 0.01).asDiagonal();
  line.start = in_robot.a;
  line.end = in_robot.b;
  return line;
}

}  // namespace

TEST(NearestNeighborAssociation, MatchesEachLineToTheWallItOverlaps) {
  const FeatureMap2D map = association_map();
  const Pose2 robot(13.0, 1.0, 0.1);
  ExtractedFeatures features;
  features.lines.push_back(measured_line(robot, {12.5, 0}, {16, 0}));   // on south_b only
  features.lines.push_back(measured_line(robot, {11, 2}, {16, 2}));     // north
  const NearestNeighborAssociation association;
  const Eigen::Matrix3d P = Eigen::Vector3d(0.01, 0.01, 0.001).asDiagonal();
  const std::vector<Association> result = association.associate(features, map, robot.vector(), P);
  ASSERT_EQ(result.size(), 2u);
  EXPECT_EQ(result[0].map_index, 1);  // south_b, not the collinear south_a it does not overlap
  EXPECT_EQ(result[0].candidates_in_gate, 1u);
  EXPECT_EQ(result[1].map_index, 2);
  EXPECT_LT(result[0].mahalanobis2, 1e-9);
  EXPECT_FALSE(association.line_visible(features.lines[0], map.lines[0], robot.vector()));
  EXPECT_TRUE(association.line_visible(features.lines[0], map.lines[1], robot.vector()));
}

TEST(NearestNeighborAssociation, LeavesAFeatureOutsideTheGateUnmatched) {
  const FeatureMap2D map = association_map();
  const Pose2 robot(5.0, 1.0, 0.0);
  ExtractedFeatures features;
  features.lines.push_back(measured_line(robot, {2, 1.5}, {8, 1.5}));  // a wall 0.5 m off any mapped one
  ExtractedPoint edge;                                                  // the mapped edge, seen where it is
  const Eigen::Vector2d edge_in_robot = robot.inverse().transform(map.edges[0].position);
  edge.z = {edge_in_robot.norm(), std::atan2(edge_in_robot.y(), edge_in_robot.x())};
  edge.covariance = Eigen::Vector2d(0.02 * 0.02, 0.01 * 0.01).asDiagonal();
  features.edges.push_back(edge);
  const NearestNeighborAssociation association;
  const Eigen::Matrix3d P = Eigen::Vector3d(0.001, 0.001, 0.0001).asDiagonal();
  const std::vector<Association> result = association.associate(features, map, robot.vector(), P);
  ASSERT_EQ(result.size(), 2u);
  EXPECT_FALSE(result[0].associated());
  EXPECT_GT(result[0].mahalanobis2, association.gate().threshold(2));
  EXPECT_TRUE(result[1].associated());
  EXPECT_EQ(result[1].map_kind, FeatureKind::kEdge);
  EXPECT_EQ(result[1].map_index, 0);
}
