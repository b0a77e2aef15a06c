// The one check of each measurement type (locd/sdk/validate.hpp), which the bridge runs on every
// sample so plugins never check again: what feature_ekf, emoi_markov, icp_explorer and ceiling_pf
// used to refuse themselves is refused here, with the topic and the field named.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "error_of.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sdk/plugin.hpp"
#include "locd/sdk/validate.hpp"

using namespace locd;
using locd::test::error_of;

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

LaserScan good_scan() {
  LaserScan s;
  s.angle_min = -1.0f;
  s.angle_increment = 0.01f;
  s.range_min = 0.05f;
  s.range_max = 30.0f;
  s.ranges.assign(50, 2.0f);
  return s;
}

}  // namespace

TEST(Validate, ScanGeometryAndReturns) {
  EXPECT_NO_THROW(validate(good_scan()));
  LaserScan empty = good_scan();
  empty.ranges.clear();
  EXPECT_NE(error_of<InputError>([&] { validate(empty); }).find("scan: empty (0 beams)"), std::string::npos);
  LaserScan all_nan = good_scan();
  std::fill(all_nan.ranges.begin(), all_nan.ranges.end(), kNaN);
  EXPECT_NE(error_of<InputError>([&] { validate(all_nan); }).find("no beam"), std::string::npos);
  LaserScan no_increment = good_scan();
  no_increment.angle_increment = 0.0f;
  EXPECT_NE(error_of<InputError>([&] { validate(no_increment); }).find("angle_increment"), std::string::npos);
  LaserScan inverted = good_scan();
  inverted.range_max = 0.01f;
  EXPECT_NE(error_of<InputError>([&] { validate(inverted); }).find("range_min < range_max"), std::string::npos);
  LaserScan bad_pose = good_scan();
  bad_pose.sensor_pose.translation().x() = std::nan("");
  EXPECT_NE(error_of<InputError>([&] { validate(bad_pose); }).find("sensor_pose"), std::string::npos);
  LaserScan intensities = good_scan();
  intensities.intensities.assign(3, 1.0f);
  EXPECT_NE(error_of<InputError>([&] { validate(intensities); }).find("intensities"), std::string::npos);
}

TEST(LaserScanReading, Rep117) {
  const float inf = std::numeric_limits<float>::infinity();
  LaserScan s = good_scan();  // range_min 0.05, range_max 30
  s.ranges = {2.0f, 0.05f, 30.0f, 31.0f, inf, -inf, kNaN, 0.0f, 0.01f};
  const RangeReading expected[] = {RangeReading::kHit,      RangeReading::kHit,      RangeReading::kNoReturn,
                                   RangeReading::kNoReturn, RangeReading::kNoReturn, RangeReading::kTooClose,
                                   RangeReading::kInvalid,  RangeReading::kInvalid,  RangeReading::kInvalid};
  for (size_t i = 0; i < s.ranges.size(); ++i) {
    EXPECT_EQ(s.reading(i), expected[i]) << "beam " << i << " = " << s.ranges[i];
    EXPECT_EQ(s.valid_return(i), expected[i] == RangeReading::kHit) << "beam " << i;
  }
  // A scan of max-range readings, infinities and NaN only has no return: refused.
  s.ranges = {30.0f, inf, -inf, kNaN, 0.0f};
  EXPECT_NE(error_of<InputError>([&] { validate(s); }).find("no beam is a return"), std::string::npos);
}

TEST(Validate, LimitsAreCheckedOnceByCount) {
  EXPECT_NO_THROW(check_limit("scan", "beams", Limits{}.max_scan_beams, Limits{}.max_scan_beams, "max_scan_beams"));
  const std::string message = error_of<InputError>(
      [] { check_limit("scan", "beams", Limits{}.max_scan_beams + 1, Limits{}.max_scan_beams, "max_scan_beams"); });
  EXPECT_NE(message.find("exceed the limit max_scan_beams = 8192"), std::string::npos) << message;
}

TEST(Validate, OdometryAndImu) {
  Odometry odometry;
  EXPECT_NO_THROW(validate(odometry));
  odometry.pose.translation().x() = std::nan("");
  EXPECT_NE(error_of<InputError>([&] { validate(odometry); }).find("odometry"), std::string::npos);
  Odometry moving;
  moving.linear_velocity.x() = std::numeric_limits<double>::infinity();
  EXPECT_NE(error_of<InputError>([&] { validate(moving); }).find("velocity"), std::string::npos);

  Imu imu;
  EXPECT_NO_THROW(validate(imu));
  Imu nan_attitude = imu;
  nan_attitude.orientation.coeffs() << NAN, 0, 0, 1;
  EXPECT_NE(error_of<InputError>([&] { validate(nan_attitude); }).find("orientation (attitude) is NaN"),
            std::string::npos);
  Imu zero = imu;
  zero.orientation.coeffs() << 0, 0, 0, 0;
  EXPECT_NE(error_of<InputError>([&] { validate(zero); }).find("zero quaternion"), std::string::npos);
  Imu bad_acceleration = imu;
  bad_acceleration.linear_acceleration.y() = std::nan("");
  EXPECT_NE(error_of<InputError>([&] { validate(bad_acceleration); }).find("acceleration"), std::string::npos);
}

TEST(Validate, CloudImageAndDetections) {
  PointCloud cloud;
  EXPECT_NE(error_of<InputError>([&] { validate(cloud); }).find("cloud: empty"), std::string::npos);
  cloud.points.assign(4, Eigen::Vector3f(kNaN, 0, 0));
  EXPECT_NE(error_of<InputError>([&] { validate(cloud); }).find("every point is NaN"), std::string::npos);
  cloud.points[2] = Eigen::Vector3f(1, 2, 3);
  EXPECT_NO_THROW(validate(cloud));  // NaN points are "no return"
  cloud.intensity.assign(3, 0.5f);
  EXPECT_NE(error_of<InputError>([&] { validate(cloud); }).find("intensities for 4 points"), std::string::npos);

  Image image;
  image.width = 4;
  image.height = 2;
  image.data.assign(8, 0);
  EXPECT_NO_THROW(validate(image));
  image.data.pop_back();
  EXPECT_NE(error_of<InputError>([&] { validate(image); }).find("bytes of data"), std::string::npos);

  LandmarkDetections frame;
  frame.detections.push_back({"sign", {1.0, 2.0, 0.0}, Eigen::Matrix3d::Identity()});
  EXPECT_NO_THROW(validate(frame));
  frame.detections[0].position.y() = std::nan("");
  EXPECT_NE(error_of<InputError>([&] { validate(frame); }).find("detection 0 has a NaN or infinite position"),
            std::string::npos);
  frame.detections[0].position.y() = 2.0;
  frame.detections[0].covariance(1, 1) = std::nan("");
  EXPECT_NE(error_of<InputError>([&] { validate(frame); }).find("NaN covariance"), std::string::npos);
  const Measurement m = frame;
  EXPECT_THROW(validate(m), InputError);
}
