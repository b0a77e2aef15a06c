#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "locd/sim/laser_scanner.hpp"
#include "locd/sim/odometry_model.hpp"
#include "locd/sim/trajectory.hpp"

using namespace locd::sim;
using locd::Pose2;

namespace {

struct Moments {
  double mean = 0, stddev = 0;
};
Moments moments(const std::vector<double>& v) {
  double sum = 0, sum2 = 0;
  for (double x : v) sum += x;
  const double mean = sum / v.size();
  for (double x : v) sum2 += (x - mean) * (x - mean);
  return {mean, std::sqrt(sum2 / (v.size() - 1))};
}

std::shared_ptr<const SegmentWorld> wall_at_x5() {
  return std::make_shared<SegmentWorld>(std::vector<Segment>{{{5, -50}, {5, 50}}});
}

}  // namespace

TEST(LaserScanner, NoiselessRangesFollowTheGeometry) {
  LaserScannerConfig config;
  config.range_noise_stddev = 0.0;
  config.range_max = 30.0;
  LaserScannerModel laser(config, wall_at_x5());
  std::mt19937_64 rng(1);
  const locd::LaserScan scan = laser.scan(Pose2(0, 0, 0), 42, rng);
  ASSERT_EQ(scan.ranges.size(), 361u);
  EXPECT_EQ(scan.header.stamp_ns, 42);
  EXPECT_NEAR(scan.angle_min, -M_PI / 2, 1e-6);
  EXPECT_NEAR(scan.angle_increment, M_PI / 360, 1e-7);
  for (size_t i = 0; i < scan.ranges.size(); ++i) {
    const double a = scan.angle(i);
    const double expected = std::abs(std::cos(a)) > 1e-9 ? 4.8 / std::cos(a) : INFINITY;  // sensor at x = 0.2
    if (expected > 0 && expected <= 30.0) {
      EXPECT_NEAR(scan.ranges[i], expected, 1e-4 * expected) << "beam " << i;
    } else {
      EXPECT_TRUE(std::isinf(scan.ranges[i])) << "beam " << i << " should have no return";
    }
  }
}

TEST(LaserScanner, RangeNoiseHasTheConfiguredStddev) {
  LaserScannerConfig config;
  config.range_noise_stddev = 0.01;
  config.beams = 181;
  LaserScannerModel laser(config, wall_at_x5());
  std::mt19937_64 rng(11);
  std::vector<double> errors;
  for (int k = 0; k < 200; ++k) {
    const locd::LaserScan scan = laser.scan(Pose2(0, 0, 0), k, rng);
    for (size_t i = 0; i < scan.ranges.size(); ++i) {
      const double a = scan.angle(i);
      if (std::cos(a) < 0.3) continue;
      errors.push_back(scan.ranges[i] - 4.8 / std::cos(a));
    }
  }
  ASSERT_GT(errors.size(), 20000u);
  const Moments m = moments(errors);
  const double standard_error = 0.01 / std::sqrt(errors.size());
  EXPECT_NEAR(m.mean, 0.0, 4 * standard_error + 2e-6);  // + float rounding of the ranges
  EXPECT_NEAR(m.stddev, 0.01, 0.01 * 0.03);
}

TEST(Odometry, IncrementStatisticsMatchTheDriftModel) {
  OdometryConfig config;
  config.drift = {0.02, 1.0, 0.02, 0.005, -0.01};
  OdometryModel odometry(config);
  std::mt19937_64 rng(5);
  const OdometryIncrement truth{0.02, 0.1, 0.016};
  std::vector<double> distance, rotation;
  for (int k = 0; k < 100000; ++k) {
    const OdometryIncrement reported = odometry.noisy(truth, rng);
    EXPECT_DOUBLE_EQ(reported.direction, truth.direction);
    distance.push_back(reported.distance);
    rotation.push_back(reported.rotation);
  }
  const Moments d = moments(distance), r = moments(rotation);
  const double sigma_d = 0.02 * std::sqrt(0.02);
  const double per_metre = M_PI / 180.0;
  const double sigma_r = std::sqrt(per_metre * per_metre * 0.02 + 0.02 * 0.02 * 0.016);
  EXPECT_NEAR(d.mean, 0.02 * 1.005, 4 * sigma_d / std::sqrt(1e5));
  EXPECT_NEAR(d.stddev, sigma_d, 0.02 * sigma_d);
  EXPECT_NEAR(r.mean, 0.016 * 0.99, 4 * sigma_r / std::sqrt(1e5));
  EXPECT_NEAR(r.stddev, sigma_r, 0.02 * sigma_r);
}

TEST(Odometry, DriftAfterOneMetreIsRateIndependent) {
  // 1 m straight at 1 m/s, at 50 Hz and at 200 Hz: position stddev 2 cm, heading stddev 1 deg.
  for (double rate : {50.0, 200.0}) {
    OdometryConfig config;
    config.rate_hz = rate;
    config.drift = {0.02, 1.0, 0.02, 0.0, 0.0};
    std::mt19937_64 rng(9);
    std::vector<double> along, heading;
    for (int run = 0; run < 2000; ++run) {
      OdometryModel odometry(config);
      locd::Odometry last;
      const int steps = static_cast<int>(rate);
      for (int k = 0; k <= steps; ++k) {
        TruthSample truth;
        truth.t = k / rate;
        truth.pose = Pose2(k / rate, 0.0, 0.0);
        last = std::get<locd::Odometry>(odometry.measure(truth, k, rng));
      }
      along.push_back(last.pose.translation().x());
      heading.push_back(locd::yaw_of(last.pose.linear()));
    }
    const Moments a = moments(along), h = moments(heading);
    EXPECT_NEAR(a.mean, 1.0, 0.003) << rate;
    EXPECT_NEAR(a.stddev, 0.02, 0.002) << rate;
    EXPECT_NEAR(h.stddev, M_PI / 180.0, 0.1 * M_PI / 180.0) << rate;
  }
}

TEST(Odometry, VelocitiesMatchThePoseIncrements) {
  OdometryConfig config;
  config.drift = {0, 0, 0, 0, 0};
  OdometryModel odometry(config);
  std::mt19937_64 rng(1);
  TruthSample a, b;
  a.pose = Pose2(1, 2, 0.5);
  b.t = 0.02;
  b.pose = a.pose * Pose2(0.02, 0.0, 0.01);
  odometry.measure(a, 0, rng);
  const auto o = std::get<locd::Odometry>(odometry.measure(b, 20'000'000, rng));
  EXPECT_NEAR(o.linear_velocity.x(), 1.0, 1e-9);
  EXPECT_NEAR(o.angular_velocity.z(), 0.5, 1e-9);
  EXPECT_NEAR(o.pose.translation().x(), 0.02, 1e-12);
  EXPECT_NEAR(locd::yaw_of(o.pose.linear()), 0.01, 1e-12);
}

TEST(Trajectory, RespectsLimitsAndPassesTheWaypoints) {
  RobotSpec robot;
  robot.start = Pose2(3, 1, 0);
  robot.max_speed = 1.0;
  robot.max_yaw_rate = 0.8;
  robot.max_acceleration = 0.5;
  robot.waypoints = {{1, 1}, {39, 1}, {39, 19}, {1, 19}};
  robot.loop = true;
  const double dt = 0.02;
  const Trajectory trajectory = Trajectory::generate(robot, 150.0, dt);
  const auto& samples = trajectory.samples();
  ASSERT_EQ(samples.size(), 7501u);
  double max_speed = 0;
  for (size_t k = 1; k < samples.size(); ++k) {
    const double step = std::hypot(samples[k].pose.x - samples[k - 1].pose.x, samples[k].pose.y - samples[k - 1].pose.y);
    const double turn = std::abs(locd::normalize_angle(samples[k].pose.theta - samples[k - 1].pose.theta));
    ASSERT_LE(step / dt, robot.max_speed + 1e-9) << "at t = " << samples[k].t;
    ASSERT_LE(turn / dt, robot.max_yaw_rate + 1e-9) << "at t = " << samples[k].t;
    ASSERT_LE(std::abs(samples[k].linear_velocity - samples[k - 1].linear_velocity), robot.max_acceleration * dt + 1e-9);
    max_speed = std::max(max_speed, step / dt);
    // Never leaves the 2 m corridor around the centre line.
    const auto& p = samples[k].pose;
    const bool in_corridor = (p.y < 2 || p.y > 18 || p.x < 2 || p.x > 38) && p.x > 0 && p.x < 40 && p.y > 0 && p.y < 20;
    ASSERT_TRUE(in_corridor) << "at t = " << samples[k].t << ": " << p.x << ", " << p.y;
  }
  EXPECT_GT(max_speed, 0.99);
  // One lap (112 m) takes a bit more than 112 s: the robot passes every waypoint and comes back.
  std::vector<Eigen::Vector2d> order = {{39, 1}, {39, 19}, {1, 19}, {1, 1}};
  size_t next = 0;
  for (const auto& s : samples) {
    if (next < order.size() && (Eigen::Vector2d(s.pose.x, s.pose.y) - order[next]).norm() < 0.5) ++next;
  }
  EXPECT_EQ(next, order.size());
  // Slower in turns: the speed at the first corner is below max_speed.
  double corner_speed = 1e9;
  for (const auto& s : samples) {
    if ((Eigen::Vector2d(s.pose.x, s.pose.y) - Eigen::Vector2d(39, 1)).norm() < 0.8) corner_speed = std::min(corner_speed, s.linear_velocity);
  }
  EXPECT_LT(corner_speed, 0.8);
}

TEST(Trajectory, OpenPathStopsAtTheLastWaypoint) {
  RobotSpec robot;
  robot.start = Pose2(0, 0, 0);
  robot.waypoints = {{0, 0}, {5, 0}, {5, 3}};
  robot.loop = false;
  const Trajectory trajectory = Trajectory::generate(robot, 40.0, 0.02);
  const auto& end = trajectory.samples().back();
  EXPECT_NEAR(end.pose.x, 5.0, 0.3);
  EXPECT_NEAR(end.pose.y, 3.0, 0.3);
  EXPECT_NEAR(end.linear_velocity, 0.0, 0.05);
  // Interpolation between samples.
  const auto mid = trajectory.at(0.01 + 10.0);
  const auto& a = trajectory.samples()[500];
  const auto& b = trajectory.samples()[501];
  EXPECT_NEAR(mid.pose.x, 0.5 * (a.pose.x + b.pose.x), 1e-12);
}

TEST(LaserScanner, DropoutsHitTheirRateInBurstsOfTheirMeanLengthWithEveryKind) {
  // A wall 5 m ahead in every direction of a 360-degree scan (a closed box): every undropped beam
  // returns about 5 m, so a dropped one is told by its reading.
  auto box = std::make_shared<SegmentWorld>(
      std::vector<Segment>{{{-5, -5}, {5, -5}}, {{5, -5}, {5, 5}}, {{5, 5}, {-5, 5}}, {{-5, 5}, {-5, -5}}});
  for (const auto& [rate, burst] : std::vector<std::pair<double, double>>{{0.05, 1.0}, {0.1, 4.0}, {0.3, 10.0}}) {
    LaserScannerConfig config;
    config.fov_deg = 360.0;
    config.beams = 720;
    config.mount = Pose2(0, 0, 0);
    config.dropouts.rate = rate;
    config.dropouts.burst_beams = burst;
    config.dropouts.kinds = {Dropout::kNan, Dropout::kZero, Dropout::kMaxRange, Dropout::kInfinity};
    LaserScannerModel laser(config, box);
    std::mt19937_64 rng(5);
    size_t beams = 0, dropped = 0, bursts = 0, nan = 0, zero = 0, max_range = 0, inf = 0;
    for (int k = 0; k < 400; ++k) {
      const locd::LaserScan scan = laser.scan(Pose2(0, 0, 0.001 * k), k, rng);
      bool previous = false;
      for (float r : scan.ranges) {
        const bool is_nan = std::isnan(r), is_zero = r == 0.0f, is_max = r == scan.range_max, is_inf = std::isinf(r);
        const bool out = is_nan || is_zero || is_max || is_inf;
        ++beams;
        dropped += out;
        bursts += out && !previous;
        nan += is_nan;
        zero += is_zero;
        max_range += is_max;
        inf += is_inf;
        if (!out) EXPECT_GT(r, 4.9f);
        previous = out;
      }
    }
    const double measured = static_cast<double>(dropped) / beams;
    // 288 000 beams in bursts of mean length L: the share's standard error is about
    // sqrt(rate (1 - rate) L' / beams) with L' ~ 2 L; 5 sigma is well inside 15 % of the rate.
    EXPECT_NEAR(measured, rate, 0.15 * rate) << "rate " << rate << " burst " << burst;
    EXPECT_NEAR(static_cast<double>(dropped) / bursts, burst, 0.15 * burst) << "rate " << rate;
    for (size_t n : {nan, zero, max_range, inf}) EXPECT_NEAR(static_cast<double>(n) / dropped, 0.25, 0.06);
  }
}

TEST(LaserScanner, DropoutErrorsNameKeyValueAndWhatIsAllowed) {
  const auto error = [](const std::string& yaml) {
    try {
      LaserScannerConfig::from_params(locd::Params::parse(yaml, "laser.yaml"));
    } catch (const locd::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error("dropouts: {rate: 0.1, burst_beams: 3, kinds: [nan, zero, max_range, inf]}\n"), "");
  const std::string kind = error("dropouts: {rate: 0.1, kinds: [nan, static]}\n");
  EXPECT_NE(kind.find("'dropouts.kinds'"), std::string::npos) << kind;
  EXPECT_NE(kind.find("'static'"), std::string::npos) << kind;
  EXPECT_NE(kind.find("allowed: nan, zero, max_range, inf"), std::string::npos) << kind;
  const std::string rate = error("dropouts: {rate: 1.5}\n");
  EXPECT_NE(rate.find("'dropouts.rate'"), std::string::npos) << rate;
  EXPECT_NE(rate.find("[0, 1)"), std::string::npos) << rate;
  const std::string reach = error("dropouts: {rate: 0.6, burst_beams: 1}\n");
  EXPECT_NE(reach.find("cannot be reached"), std::string::npos) << reach;
  EXPECT_NE(error("dropouts: {rate: 0.1, burst: 3}\n").find("unknown parameter 'dropouts.burst'"), std::string::npos);
}
