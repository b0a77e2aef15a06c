// Wire -> sdk conversions: limits are enforced before anything is read or allocated, bad values
// are rejected with messages naming the topic and the field.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>

#include "error_of.hpp"
#include "locd/dds/convert.hpp"

using namespace locd;
using locd::test::error_of;

namespace {

template <typename T>
T zeroed() {
  T v;
  std::memset(&v, 0, sizeof(v));
  return v;
}

locd_msg_LaserScan scan_of(std::vector<float>& ranges) {
  auto m = zeroed<locd_msg_LaserScan>();
  m.sensor_pose.orientation.w = 1.0;
  m.angle_min = -1.0f;
  m.angle_increment = 0.01f;
  m.range_min = 0.1f;
  m.range_max = 30.0f;
  m.ranges._buffer = ranges.data();
  m.ranges._length = m.ranges._maximum = static_cast<uint32_t>(ranges.size());
  return m;
}

}  // namespace

TEST(Convert, OversizedScanRejectedBeforeReadingIt) {
  Limits limits;
  limits.max_scan_beams = 100;
  auto m = zeroed<locd_msg_LaserScan>();
  m.ranges._length = 101;  // buffer deliberately null: reading it would crash
  const std::string msg = error_of<InputError>([&] { dds::from_wire(m, limits); });
  EXPECT_NE(msg.find("max_scan_beams"), std::string::npos) << msg;
  EXPECT_NE(msg.find("101"), std::string::npos) << msg;
}

TEST(Convert, ScanValuesSurvive) {
  std::vector<float> ranges{1.0f, std::numeric_limits<float>::quiet_NaN(), 2.5f};
  auto m = scan_of(ranges);
  m.header.stamp_ns = 1234;
  std::strcpy(m.header.frame_id, "laser");
  const LaserScan s = dds::from_wire(m, Limits{});
  EXPECT_EQ(s.header.stamp_ns, 1234);
  EXPECT_EQ(s.header.frame_id, "laser");
  ASSERT_EQ(s.ranges.size(), 3u);
  EXPECT_TRUE(s.valid_return(0));
  EXPECT_FALSE(s.valid_return(1));
  EXPECT_FLOAT_EQ(s.ranges[2], 2.5f);
}

TEST(Convert, EmptyAndAllNanScansRejected) {
  std::vector<float> none;
  auto empty = scan_of(none);
  EXPECT_NE(error_of<InputError>([&] { dds::from_wire(empty, Limits{}); }).find("empty"), std::string::npos);
  std::vector<float> nan(5, std::numeric_limits<float>::quiet_NaN());
  auto all_nan = scan_of(nan);
  EXPECT_NE(error_of<InputError>([&] { dds::from_wire(all_nan, Limits{}); }).find("no beam"), std::string::npos);
  std::vector<float> ok{1.0f};
  auto bad_pose = scan_of(ok);
  bad_pose.sensor_pose.position.x = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(error_of<InputError>([&] { dds::from_wire(bad_pose, Limits{}); }).find("sensor_pose"), std::string::npos);
}

TEST(Convert, CloudLimitsAndNanPoints) {
  Limits limits;
  limits.max_cloud_points = 2;
  auto big = zeroed<locd_msg_PointCloud>();
  big.xyz._length = 9;  // 3 points, null buffer
  EXPECT_NE(error_of<InputError>([&] { dds::from_wire(big, limits); }).find("max_cloud_points"), std::string::npos);
  std::vector<float> xyz{1, 2, 3, NAN, 0, 0};
  auto m = zeroed<locd_msg_PointCloud>();
  m.sensor_pose.orientation.w = 1;
  m.xyz._buffer = xyz.data();
  m.xyz._length = 6;
  const PointCloud c = dds::from_wire(m, limits);
  ASSERT_EQ(c.points.size(), 1u);
  EXPECT_EQ(c.points[0], Eigen::Vector3f(1, 2, 3));
}

TEST(Convert, ImageEncodingAndSize) {
  Limits limits;
  limits.max_image_pixels = 100;
  std::vector<uint8_t> data(4 * 3 * 2, 7);
  auto m = zeroed<locd_msg_Image>();
  m.width = 4;
  m.height = 2;
  m.step = 12;
  std::strcpy(m.encoding, "bgr8");
  m.data._buffer = data.data();
  m.data._length = static_cast<uint32_t>(data.size());
  const Image img = dds::from_wire(m, limits);
  EXPECT_EQ(img.channels, 3);
  EXPECT_EQ(img.data.size(), 24u);
  std::strcpy(m.encoding, "rgb16");
  EXPECT_NE(error_of<InputError>([&] { dds::from_wire(m, limits); }).find("allowed: mono8, bgr8"), std::string::npos);
  std::strcpy(m.encoding, "mono8");
  m.width = 20;
  m.height = 20;  // 400 pixels > 100
  EXPECT_NE(error_of<InputError>([&] { dds::from_wire(m, limits); }).find("max_image_pixels"), std::string::npos);
}

TEST(Convert, NanAttitudeRejected) {
  auto m = zeroed<locd_msg_Imu>();
  m.orientation.w = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(error_of<InputError>([&] { dds::from_wire(m); }).find("attitude"), std::string::npos);
}

TEST(Convert, PoseRoundTrip) {
  const Eigen::Isometry3d T = Eigen::Translation3d(1, 2, 3) * Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized());
  locd_msg_Pose3D wire{};
  dds::to_wire(T, wire);
  EXPECT_TRUE(dds::from_wire(wire).isApprox(T, 1e-12));
  wire.orientation = {0, 0, 0, 0};
  EXPECT_THROW(dds::from_wire(wire), InputError);
}

TEST(Convert, OversizedDetectionFramesRejectedBeforeReadingThem) {
  Limits limits;
  limits.max_detections = 4;
  auto m = zeroed<locd_msg_LandmarkDetections>();
  m.detections._length = 5;  // buffer deliberately null: reading it would crash
  const std::string msg = error_of<InputError>([&] { dds::from_wire(m, limits); });
  EXPECT_NE(msg.find("max_detections"), std::string::npos) << msg;
}
