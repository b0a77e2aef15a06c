// The landmark models of issue 3: eq. 7-9 Jacobians against finite differences, WGS84 radii
// (eq. 8), the measurement mapping (eq. 10-12), the PDA update against its direct formula, and
// the landmark database files.
#include <gtest/gtest.h>

#include <functional>
#include <random>

#include "error_of.hpp"
#include "locd/feature_ekf/extended_kalman_filter.hpp"
#include "locd/feature_ekf/geodetic_models.hpp"
#include "locd/feature_ekf/landmark_database.hpp"
#include "locd/sdk/errors.hpp"

using namespace locd;
using namespace locd::feature_ekf;

namespace {

constexpr double kDegree = M_PI / 180.0;

using locd::test::error_of;

OperatingArea area() { return OperatingArea::centred_at(36.1 * kDegree, 129.37 * kDegree, 50.0); }


}  // namespace

TEST(LandmarkModels, EarthRadiiFollowWgs84) {
  const EarthRadii equator = earth_radii(0.0);
  EXPECT_NEAR(equator.meridian, wgs84::kSemiMajorAxis * (1.0 - wgs84::kEccentricity2), 1e-6);
  EXPECT_NEAR(equator.transverse, wgs84::kSemiMajorAxis, 1e-6);
  const EarthRadii pole = earth_radii(M_PI / 2);
  EXPECT_NEAR(pole.meridian, pole.transverse, 1e-6);
  EXPECT_NEAR(pole.transverse, 6399593.6258, 1e-3);  // a / sqrt(1 - e^2)
}

TEST(LandmarkModels, GeodeticJacobianMatchesFiniteDifferences) {
  const HorizontalModel model(LandmarkModelKind::kGeodetic, area());
  std::mt19937_64 rng(4);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    HorizontalModel::State x;
    x << (36.1 + 0.3 * n(rng)) * kDegree, (129.37 + 0.3 * n(rng)) * kDegree, 15.0 * n(rng), 15.0 * n(rng);
    const Eigen::Vector2d force(n(rng), n(rng));
    const double dt = 0.0025;
    const HorizontalModel::StateMatrix F = model.transition_jacobian(x, dt);
    const Eigen::Vector4d steps(1e-7, 1e-7, 1e-4, 1e-4);
    for (int j = 0; j < 4; ++j) {
      HorizontalModel::State plus = x, minus = x;
      plus(j) += steps(j);
      minus(j) -= steps(j);
      const HorizontalModel::State column = (model.predict(plus, force, dt) - model.predict(minus, force, dt)) / (2 * steps(j));
      for (int i = 0; i < 4; ++i) {
        EXPECT_NEAR(F(i, j), column(i), 1e-7 * std::max(1.0, std::fabs(column(i)))) << "F(" << i << ", " << j << ")";
      }
    }
    // dg/dx, whose entries are tiny next to the identity, checked on its own (steps large
    // enough that rounding stays below the tolerance, small enough for the truncation error).
    const HorizontalModel::StateMatrix G = model.derivative_jacobian(x);
    const Eigen::Vector4d g_steps(1e-5, 1e-5, 1e-2, 1e-2);
    for (int j = 0; j < 4; ++j) {
      HorizontalModel::State plus = x, minus = x;
      plus(j) += g_steps(j);
      minus(j) -= g_steps(j);
      const HorizontalModel::State column = (model.derivative(plus, force) - model.derivative(minus, force)) / (2 * g_steps(j));
      for (int i = 0; i < 4; ++i) {
        EXPECT_NEAR(G(i, j), column(i), 1e-6 * std::fabs(column(i)) + 1e-15) << "dg/dx(" << i << ", " << j << ")";
      }
    }
  }
}

TEST(LandmarkModels, GeodeticDerivativeIsEquation7) {
  const OperatingArea a = area();
  const HorizontalModel model(LandmarkModelKind::kGeodetic, a);
  HorizontalModel::State x;
  x << a.latitude, a.longitude, 10.0, 0.0;  // 10 m/s north
  const HorizontalModel::State g = model.derivative(x, Eigen::Vector2d(0.5, -0.2));  // fE, fN
  EXPECT_NEAR(g(0), 10.0 / (a.radii.meridian + a.altitude), 1e-15);
  EXPECT_NEAR(g(1), 0.0, 1e-18);
  EXPECT_NEAR(g(2), -0.2, 1e-12);  // no east velocity: no Coriolis or transport term on vN
  EXPECT_NEAR(g(3), 0.5 + 2.0 * wgs84::kEarthRate * 10.0 * std::sin(a.latitude), 1e-12);
}

TEST(LandmarkModels, EnuModelIsLinearKinematics) {
  const HorizontalModel model(LandmarkModelKind::kEnu, area());
  HorizontalModel::State x(1.0, 2.0, 3.0, 4.0);
  const HorizontalModel::State next = model.predict(x, Eigen::Vector2d(0.5, -1.0), 0.1);
  EXPECT_TRUE(next.isApprox(HorizontalModel::State(1.3, 2.4, 3.05, 3.9)));
  HorizontalModel::StateMatrix F = HorizontalModel::StateMatrix::Identity();
  F(0, 2) = F(1, 3) = 0.1;
  EXPECT_TRUE(model.transition_jacobian(x, 0.1).isApprox(F));
}

TEST(LandmarkModels, MeasurementRecoversTheVehiclePosition) {
  // Eq. 10-12: y = l - T z is the vehicle's position when z is the exact relative position.
  for (LandmarkModelKind kind : {LandmarkModelKind::kGeodetic, LandmarkModelKind::kEnu}) {
    const HorizontalModel model(kind, area());
    const Eigen::Vector2d vehicle(310.0, -420.0), landmark(336.0, -395.0);  // ENU m
    const double yaw = 0.7;
    const Eigen::Quaterniond attitude(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
    const Eigen::Vector3d body = attitude.inverse() * Eigen::Vector3d(landmark.x() - vehicle.x(), landmark.y() - vehicle.y(), 1.5);
    Eigen::Vector2d offset;
    Eigen::Matrix2d covariance;
    body_to_horizontal(attitude, body, Eigen::Matrix3d::Identity() * 4.0, &offset, &covariance);
    EXPECT_TRUE(offset.isApprox(landmark - vehicle, 1e-12));
    EXPECT_TRUE(covariance.isApprox(4.0 * Eigen::Matrix2d::Identity(), 1e-12));
    const Eigen::Vector2d geodetic = model.area().to_geodetic(landmark);
    const LandmarkMeasurement m = landmark_measurement(model, offset, covariance);
    const Eigen::Vector2d y = model.landmark_position(geodetic.x(), geodetic.y()) - m.offset;
    const Eigen::Vector2d recovered = model.position_enu((HorizontalModel::State() << y, 0.0, 0.0).finished());
    EXPECT_LT((recovered - vehicle).norm(), 1e-6) << landmark_model_name(kind);
    // R = T R_p T^T: back in metres it is R_p.
    const Eigen::Matrix2d T_inv = model.position_per_metre().inverse();
    EXPECT_TRUE((T_inv * m.covariance * T_inv.transpose()).isApprox(covariance, 1e-9));
  }
}

TEST(LandmarkModels, EnuJacobianMatchesFiniteDifferences) {
  const HorizontalModel model(LandmarkModelKind::kGeodetic, area());
  HorizontalModel::State x = model.state_from_enu({120.0, -80.0}, {3.0, -4.0});
  const HorizontalModel::StateMatrix J = model.enu_jacobian();
  const Eigen::Vector4d steps(1e-8, 1e-8, 1e-3, 1e-3);
  for (int j = 0; j < 4; ++j) {
    HorizontalModel::State plus = x, minus = x;
    plus(j) += steps(j);
    minus(j) -= steps(j);
    Eigen::Vector4d f_plus, f_minus;
    f_plus << model.position_enu(plus), model.velocity_enu(plus);
    f_minus << model.position_enu(minus), model.velocity_enu(minus);
    const Eigen::Vector4d column = (f_plus - f_minus) / (2 * steps(j));
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(J(i, j), column(i), 1e-6 * std::max(1.0, std::fabs(column(i))));
  }
}

TEST(LandmarkModels, MixtureUpdateWithOneCertainHypothesisIsTheKalmanUpdate) {
  ExtendedKalmanFilter<4> a(Eigen::Vector4d(1, 2, 3, 4), Eigen::Vector4d(4, 5, 1, 2).asDiagonal());
  ExtendedKalmanFilter<4> b = a;
  Eigen::Matrix<double, 2, 4> H = Eigen::Matrix<double, 2, 4>::Zero();
  H(0, 0) = H(1, 1) = 1.0;
  const Eigen::Matrix2d R = Eigen::Matrix2d::Identity() * 2.0;
  const Eigen::Vector2d r(0.5, -1.0);
  ASSERT_TRUE(a.update<2>(r, H, R));
  ASSERT_TRUE(b.update_mixture<2>({{r, 1.0}}, 0.0, H, R));
  EXPECT_TRUE(a.state().isApprox(b.state(), 1e-12));
  EXPECT_TRUE(a.covariance().isApprox(b.covariance(), 1e-12));
}

TEST(LandmarkModels, MixtureUpdateMatchesTheDirectPdaFormula) {
  const Eigen::Vector4d x0(1, 2, 3, 4);
  const Eigen::Matrix4d P0 = Eigen::Vector4d(4, 5, 1, 2).asDiagonal();
  ExtendedKalmanFilter<4> f(x0, P0);
  Eigen::Matrix<double, 2, 4> H = Eigen::Matrix<double, 2, 4>::Zero();
  H(0, 0) = H(1, 1) = 1.0;
  const Eigen::Matrix2d R = Eigen::Matrix2d::Identity();
  const Eigen::Vector2d r1(1.0, 0.0), r2(-2.0, 1.0);
  const double b1 = 0.5, b2 = 0.3, b0 = 0.2;
  ASSERT_TRUE(f.update_mixture<2>({{r1, b1}, {r2, b2}}, b0, H, R));
  // Direct: W = P H^T S^-1, P_c = P - W S W^T (equal to the Joseph form with the optimal W).
  const Eigen::Matrix2d S = H * P0 * H.transpose() + R;
  const Eigen::Matrix<double, 4, 2> W = P0 * H.transpose() * S.inverse();
  const Eigen::Vector2d nu = b1 * r1 + b2 * r2;
  const Eigen::Matrix4d Pc = P0 - W * S * W.transpose();
  const Eigen::Matrix2d spread = b1 * r1 * r1.transpose() + b2 * r2 * r2.transpose() - nu * nu.transpose();
  EXPECT_TRUE(f.state().isApprox(x0 + W * nu, 1e-12));
  EXPECT_TRUE(f.covariance().isApprox(b0 * P0 + (1 - b0) * Pc + W * spread * W.transpose(), 1e-12));
}

TEST(LandmarkDatabase, ReadsCsvAndYaml) {
  const LandmarkDatabase csv = parse_landmark_csv(
      "# signs\nid,class,lat,lon\na1,stop,36.1,129.3\na2, stop ,36.2,129.4\nb1,yield,-36.0,-129.0\n", "t.csv", 100);
  ASSERT_EQ(csv.size(), 3u);
  EXPECT_EQ(csv.of_class("stop").size(), 2u);
  EXPECT_EQ(csv.of_class("yield"), std::vector<int>{2});
  EXPECT_TRUE(csv.of_class("none").empty());
  EXPECT_EQ(csv.index_of("a2"), 1);
  const LandmarkDatabase yaml = parse_landmark_yaml(
      "landmarks:\n  - {id: a1, class: stop, lat: 36.1, lon: 129.3}\n  - {id: a2, class: stop, lat: 36.2, lon: 129.4}\n",
      "t.yaml", 100);
  EXPECT_EQ(yaml.size(), 2u);
  EXPECT_DOUBLE_EQ(yaml[1].longitude_deg, 129.4);
}

TEST(LandmarkDatabase, RejectsBadFilesWithClearMessages) {
  EXPECT_NE(error_of([] { parse_landmark_csv("id,class,lat,lon\na,stop,1,2\na,yield,3,4\n", "t.csv", 10); })
                .find("duplicate id 'a'"),
            std::string::npos);
  const std::string lat = error_of([] { parse_landmark_csv("id,class,lat,lon\na,stop,91,2\n", "t.csv", 10); });
  EXPECT_NE(lat.find("lat 91"), std::string::npos) << lat;
  EXPECT_NE(lat.find("[-90, 90]"), std::string::npos) << lat;
  EXPECT_NE(error_of([] { parse_landmark_csv("id,class,lat,lon\na,stop,1,200\n", "t.csv", 10); }).find("lon 200"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_landmark_csv("id,class,lat,lon\na,stop,north,2\n", "t.csv", 10); }).find("'north' is not a number"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_landmark_csv("name,lat,lon\n", "t.csv", 10); }).find("must be 'id,class,lat,lon'"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_landmark_csv("id,class,lat,lon\na,stop,1\n", "t.csv", 10); }).find("line 2: 3 fields"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_landmark_csv("id,class,lat,lon\na,s,1,2\nb,s,1,2\n", "t.csv", 1); }).find("more than 1"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_landmark_yaml("landmarks:\n  - {id: a, class: s, lat: 1}\n", "t.yaml", 10); }).find("missing 'lon'"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_landmark_yaml("landmarks:\n  - {id: a, class: s, lat: 1, lon: 2, h: 3}\n", "t.yaml", 10); })
                .find("unknown key 'h'"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_landmark_yaml("signs: []\n", "t.yaml", 10); }).find("expected a list"), std::string::npos);
}
