// ROS 2 messages -> sdk types: the PointCloud2 layouts real drivers send (x, y, z as FLOAT32 or
// FLOAT64, optional intensity, NaN points, padded rows, big-endian data), the image encodings,
// IMU frames and gravity, stamps; every refusal names the field and what is allowed, and sizes
// are refused before anything is read. Writers are read back through an in-process DDS reader.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <thread>
#include <vector>

#include "error_of.hpp"
#include "locd/dds/ros2_convert.hpp"

using namespace locd;
namespace ros2 = locd::dds::ros2;
using locd::test::error_of;

namespace {

constexpr int kDomain = 149;  // the writers read back in-process
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

template <typename T>
T zeroed() {
  T v;
  std::memset(&v, 0, sizeof(v));
  return v;
}

template <typename Seq, typename Item>
void borrow(Seq& seq, Item* data, size_t n) {
  seq._buffer = data;
  seq._length = seq._maximum = static_cast<uint32_t>(n);
  seq._release = false;
}

ros2::Frames frames() {
  ros2::Frames f;
  Eigen::Isometry3d lidar = Eigen::Isometry3d::Identity();
  lidar.translation() = Eigen::Vector3d(0.1, 0.0, 0.5);
  f.sensor_frames["lidar"] = lidar;
  return f;
}

// Bytes of `value` in the given byte order.
template <typename V>
void append(std::vector<uint8_t>& out, V value, bool big_endian) {
  uint8_t raw[sizeof(V)];
  std::memcpy(raw, &value, sizeof(V));
  const uint16_t one = 1;
  uint8_t first = 0;
  std::memcpy(&first, &one, 1);
  const bool host_big = first == 0;
  if (host_big != big_endian) std::reverse(raw, raw + sizeof(V));
  out.insert(out.end(), raw, raw + sizeof(V));
}

// A cloud as a driver builds it: fields, then rows of points padded to row_step.
struct CloudBuilder {
  std::vector<ros2::PointField> fields;
  std::vector<uint8_t> data;
  uint32_t point_step = 0;
  uint32_t row_padding = 0;
  bool big_endian = false;
  uint32_t width = 0, height = 1;

  void field(const char* name, uint32_t offset, uint8_t datatype, uint32_t count = 1) {
    auto f = zeroed<ros2::PointField>();
    std::strcpy(f.name, name);
    f.offset = offset;
    f.datatype = datatype;
    f.count = count;
    fields.push_back(f);
  }
  ros2::PointCloud2 message() {
    auto m = zeroed<ros2::PointCloud2>();
    m.header.stamp = {100, 5};
    std::strcpy(m.header.frame_id, "lidar");
    m.height = height;
    m.width = width;
    borrow(m.fields, fields.data(), fields.size());
    m.is_bigendian = big_endian;
    m.point_step = point_step;
    m.row_step = width * point_step + row_padding;
    borrow(m.data, data.data(), data.size());
    return m;
  }
};

// x, y, z, intensity as FLOAT32 (16 bytes a point) or x, y, z FLOAT64 + UINT16 intensity.
CloudBuilder float32_cloud(const std::vector<Eigen::Vector4f>& points, bool big_endian = false) {
  CloudBuilder b;
  b.field("x", 0, ros2::kFloat32);
  b.field("y", 4, ros2::kFloat32);
  b.field("z", 8, ros2::kFloat32);
  b.field("intensity", 12, ros2::kFloat32);
  b.point_step = 16;
  b.big_endian = big_endian;
  b.width = static_cast<uint32_t>(points.size());
  for (const auto& p : points) {
    for (int k = 0; k < 4; ++k) append(b.data, p[k], big_endian);
  }
  return b;
}

}  // namespace

TEST(Ros2Stamps, NanosecondsAndBack) {
  EXPECT_EQ(ros2::stamp_ns({1, 500}), 1'000'000'500);
  EXPECT_EQ(ros2::stamp_ns({-2, 300'000'000}), -1'700'000'000);  // -1.7 s, as Time.msg spells it
  for (int64_t ns : {int64_t{1'700'000'000'123'456'789}, int64_t{-1'700'000'000}, int64_t{1}}) {
    const ros2::Time t = ros2::to_time(ns);
    EXPECT_LT(t.nanosec, 1'000'000'000u);
    EXPECT_EQ(ros2::stamp_ns(t), ns);
  }
  EXPECT_NE(error_of<InputError>([] { ros2::stamp_ns({0, 0}); }).find("header.stamp is zero"), std::string::npos);
  EXPECT_NE(error_of<InputError>([] { ros2::stamp_ns({1, 1'000'000'000}); }).find("nanosec = 1000000000"),
            std::string::npos);
}

TEST(Ros2PointCloud2, Float32WithIntensity) {
  auto b = float32_cloud({{1, 2, 3, 10}, {4, 5, 6, 20}});
  const PointCloud c = ros2::from_ros2(b.message(), frames(), Limits{});
  ASSERT_EQ(c.points.size(), 2u);
  EXPECT_EQ(c.points[1], Eigen::Vector3f(4, 5, 6));
  ASSERT_EQ(c.intensity.size(), 2u);
  EXPECT_EQ(c.intensity[1], 20.0f);
  EXPECT_EQ(c.header.stamp_ns, 100'000'000'005);
  EXPECT_EQ(c.header.frame_id, "lidar");
  EXPECT_TRUE(c.sensor_pose.translation().isApprox(Eigen::Vector3d(0.1, 0.0, 0.5)));
}

TEST(Ros2PointCloud2, Float64WithoutIntensityAndPaddedRows) {
  CloudBuilder b;
  b.field("x", 0, ros2::kFloat64);
  b.field("y", 8, ros2::kFloat64);
  b.field("z", 16, ros2::kFloat64);
  b.field("ring", 24, ros2::kUint16);  // a channel locd does not read
  b.point_step = 28;
  b.width = 2;
  b.height = 2;
  b.row_padding = 7;
  for (int row = 0; row < 2; ++row) {
    for (int col = 0; col < 2; ++col) {
      append(b.data, 10.0 * row + col, false);
      append(b.data, -1.0 * col, false);
      append(b.data, 0.5, false);
      append(b.data, uint16_t{7}, false);
      b.data.insert(b.data.end(), 2, 0xDD);  // point padding to point_step
    }
    b.data.insert(b.data.end(), 7, 0xEE);  // row padding
  }
  const PointCloud c = ros2::from_ros2(b.message(), frames(), Limits{});
  ASSERT_EQ(c.points.size(), 4u);
  EXPECT_EQ(c.points[3], Eigen::Vector3f(11, -1, 0.5));
  EXPECT_EQ(c.points[2], Eigen::Vector3f(10, 0, 0.5));
  EXPECT_TRUE(c.intensity.empty());
}

TEST(Ros2PointCloud2, NotDenseNaNPointsAreSkipped) {
  auto b = float32_cloud({{1, 2, 3, 10}, {kNaN, kNaN, kNaN, 0}, {4, 5, 6, 30}});
  auto m = b.message();
  m.is_dense = false;
  const PointCloud c = ros2::from_ros2(m, frames(), Limits{});
  ASSERT_EQ(c.points.size(), 2u);
  EXPECT_EQ(c.points[1], Eigen::Vector3f(4, 5, 6));
  EXPECT_EQ(c.intensity, (std::vector<float>{10, 30}));  // still one per point kept
}

TEST(Ros2PointCloud2, BigEndianData) {
  auto b = float32_cloud({{1.5f, -2.5f, 3.25f, 99}, {7, 8, 9, 1}}, true);
  const PointCloud c = ros2::from_ros2(b.message(), frames(), Limits{});
  ASSERT_EQ(c.points.size(), 2u);
  EXPECT_EQ(c.points[0], Eigen::Vector3f(1.5f, -2.5f, 3.25f));
  EXPECT_EQ(c.intensity[0], 99.0f);

  CloudBuilder d;  // FLOAT64 coordinates and a UINT16 intensity, big-endian
  d.field("x", 0, ros2::kFloat64);
  d.field("y", 8, ros2::kFloat64);
  d.field("z", 16, ros2::kFloat64);
  d.field("intensity", 24, ros2::kUint16);
  d.point_step = 26;
  d.width = 1;
  d.big_endian = true;
  append(d.data, 123.25, true);
  append(d.data, -0.5, true);
  append(d.data, 2.0, true);
  append(d.data, uint16_t{513}, true);
  const PointCloud e = ros2::from_ros2(d.message(), frames(), Limits{});
  ASSERT_EQ(e.points.size(), 1u);
  EXPECT_EQ(e.points[0], Eigen::Vector3f(123.25f, -0.5f, 2.0f));
  EXPECT_EQ(e.intensity[0], 513.0f);
}

TEST(Ros2PointCloud2, BadLayoutsAreRefusedByName) {
  auto length = float32_cloud({{1, 2, 3, 4}, {5, 6, 7, 8}});
  length.data.resize(20);
  const std::string short_data = error_of<InputError>([&] { ros2::from_ros2(length.message(), frames(), Limits{}); });
  EXPECT_NE(short_data.find("data has 20 bytes; expected row_step * height = 32 * 1 = 32 (width 2, point_step 16)"),
            std::string::npos) << short_data;

  auto unknown = float32_cloud({{1, 2, 3, 4}});
  unknown.fields[3].datatype = 9;
  const std::string unknown_type = error_of<InputError>([&] { ros2::from_ros2(unknown.message(), frames(), Limits{}); });
  EXPECT_NE(unknown_type.find("field 'intensity' has datatype 9, which is no PointField type"), std::string::npos)
      << unknown_type;

  auto integer = float32_cloud({{1, 2, 3, 4}});
  integer.fields[0].datatype = ros2::kInt16;
  const std::string int_x = error_of<InputError>([&] { ros2::from_ros2(integer.message(), frames(), Limits{}); });
  EXPECT_NE(int_x.find("field 'x' is INT16 (datatype 3); x, y and z must be FLOAT32 (7) or FLOAT64 (8)"),
            std::string::npos) << int_x;

  auto no_z = float32_cloud({{1, 2, 3, 4}});
  std::strcpy(no_z.fields[2].name, "w");
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(no_z.message(), frames(), Limits{}); }).find("no field 'z'"),
            std::string::npos);

  auto beyond = float32_cloud({{1, 2, 3, 4}});
  beyond.fields[3].offset = 14;
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(beyond.message(), frames(), Limits{}); })
                .find("ends at byte 18, beyond point_step 16"),
            std::string::npos);

  auto rows = float32_cloud({{1, 2, 3, 4}, {5, 6, 7, 8}});
  auto short_rows = rows.message();
  short_rows.row_step = 20;
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(short_rows, frames(), Limits{}); })
                .find("row_step 20 is shorter than width * point_step = 2 * 16 = 32"),
            std::string::npos);

  auto unknown_frame = float32_cloud({{1, 2, 3, 4}});
  auto m = unknown_frame.message();
  std::strcpy(m.header.frame_id, "velodyne");
  const std::string frame = error_of<InputError>([&] { ros2::from_ros2(m, frames(), Limits{}); });
  EXPECT_NE(frame.find("frame 'velodyne' is neither the base frame 'base_link' nor in ros2.sensor_frames"),
            std::string::npos) << frame;

  auto zero_stamp = float32_cloud({{1, 2, 3, 4}});
  auto z = zero_stamp.message();
  z.header.stamp = {0, 0};
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(z, frames(), Limits{}); }).find("header.stamp is zero"),
            std::string::npos);
}

TEST(Ros2PointCloud2, OversizedCloudRefusedBeforeReadingIt) {
  auto m = zeroed<ros2::PointCloud2>();
  m.header.stamp = {1, 0};
  m.width = 100000;
  m.height = 100000;  // 10^10 points, and no data behind them: nothing may be read
  Limits limits;
  limits.max_cloud_points = 1000;
  const std::string e = error_of<InputError>([&] { ros2::from_ros2(m, frames(), limits); });
  EXPECT_NE(e.find("exceed the limit max_cloud_points = 1000"), std::string::npos) << e;
}

TEST(Ros2Image, EncodingsBecomeMonoOrBgr) {
  auto m = zeroed<ros2::Image>();
  m.header.stamp = {3, 0};
  m.width = 2;
  m.height = 2;
  std::strcpy(m.encoding, "rgb8");
  m.step = 8;  // 6 bytes of pixels + 2 of padding per row
  std::vector<uint8_t> data = {1, 2, 3, 4, 5, 6, 0, 0, 7, 8, 9, 10, 11, 12, 0, 0};
  borrow(m.data, data.data(), data.size());
  const Image rgb = ros2::from_ros2(m, Limits{});
  EXPECT_EQ(rgb.channels, 3);
  EXPECT_EQ(rgb.data, (std::vector<uint8_t>{3, 2, 1, 6, 5, 4, 9, 8, 7, 12, 11, 10}));

  std::strcpy(m.encoding, "bgr8");
  EXPECT_EQ(ros2::from_ros2(m, Limits{}).data, (std::vector<uint8_t>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}));

  std::strcpy(m.encoding, "rgba8");  // the same bytes as two RGBA pixels a row, no padding
  EXPECT_EQ(ros2::from_ros2(m, Limits{}).data, (std::vector<uint8_t>{3, 2, 1, 0, 6, 5, 9, 8, 7, 0, 12, 11}));

  std::strcpy(m.encoding, "mono8");
  m.step = 4;
  std::vector<uint8_t> mono = {1, 2, 0, 0, 3, 4, 0, 0};
  borrow(m.data, mono.data(), mono.size());
  const Image gray = ros2::from_ros2(m, Limits{});
  EXPECT_EQ(gray.channels, 1);
  EXPECT_EQ(gray.data, (std::vector<uint8_t>{1, 2, 3, 4}));
}

TEST(Ros2Image, BadImagesAreRefusedByName) {
  auto m = zeroed<ros2::Image>();
  m.header.stamp = {3, 0};
  m.width = 2;
  m.height = 2;
  std::strcpy(m.encoding, "yuv422");
  m.step = 4;
  std::vector<uint8_t> data(8);
  borrow(m.data, data.data(), data.size());
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m, Limits{}); })
                .find("encoding 'yuv422' is not supported; allowed: mono8, bgr8, rgb8, bgra8, rgba8"),
            std::string::npos);
  std::strcpy(m.encoding, "mono8");
  m.data._length = 7;
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m, Limits{}); })
                .find("7 bytes of data, expected step * height = 8"),
            std::string::npos);
  Limits small;
  small.max_image_pixels = 3;
  m.data._length = 8;
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m, small); }).find("max_image_pixels = 3"), std::string::npos);
}

TEST(Ros2LaserScan, Rep117ReadingsReachThePluginUnchanged) {
  // REP 117: NaN (an invalid reading), +inf (no return within range), -inf (an object closer than
  // range_min), and finite ranges outside [range_min, range_max]: each means something, so the
  // ROS 2 path hands every one over bit for bit and the plugins' beam classification decides.
  auto m = zeroed<ros2::LaserScan>();
  m.header.stamp = {6, 0};
  std::strcpy(m.header.frame_id, "lidar");
  m.angle_min = -1.0f;
  m.angle_increment = 0.25f;
  m.range_min = 0.1f;
  m.range_max = 10.0f;
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> ranges = {2.0f, kNaN, inf, -inf, 0.05f, 10.0f, 12.0f, 0.0f, -1.0f};
  borrow(m.ranges, ranges.data(), ranges.size());
  const LaserScan s = ros2::from_ros2(m, frames(), Limits{});
  ASSERT_EQ(s.ranges.size(), ranges.size());
  EXPECT_EQ(std::memcmp(s.ranges.data(), ranges.data(), ranges.size() * sizeof(float)), 0);
  EXPECT_FLOAT_EQ(s.range_min, 0.1f);
  EXPECT_FLOAT_EQ(s.range_max, 10.0f);
}

TEST(Ros2LaserScan, ConvertsAndRefusesMismatchedIntensities) {
  auto m = zeroed<ros2::LaserScan>();
  m.header.stamp = {5, 250};
  std::strcpy(m.header.frame_id, "lidar");
  m.angle_min = -1.0f;
  m.angle_max = 1.0f;
  m.angle_increment = 1.0f;
  m.range_min = 0.1f;
  m.range_max = 10.0f;
  std::vector<float> ranges = {1.0f, std::numeric_limits<float>::infinity(), 3.0f};
  std::vector<float> intensities = {1.0f, 2.0f};
  borrow(m.ranges, ranges.data(), ranges.size());
  const LaserScan s = ros2::from_ros2(m, frames(), Limits{});
  EXPECT_EQ(s.ranges.size(), 3u);
  EXPECT_EQ(s.header.stamp_ns, 5'000'000'250);
  EXPECT_FLOAT_EQ(s.angle_increment, 1.0f);
  EXPECT_TRUE(s.sensor_pose.translation().isApprox(Eigen::Vector3d(0.1, 0.0, 0.5)));
  borrow(m.intensities, intensities.data(), intensities.size());
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m, frames(), Limits{}); })
                .find("2 intensities for 3 ranges; send none or one per range"),
            std::string::npos);
  Limits small;
  small.max_scan_beams = 2;
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m, frames(), small); }).find("max_scan_beams = 2"),
            std::string::npos);
}

TEST(Ros2Imu, RotatedIntoTheBaseFrameWithoutGravity) {
  // An IMU mounted turned 90 degrees about z, the robot level and still, heading 0.3 rad.
  ros2::Frames f;
  Eigen::Isometry3d imu_pose = Eigen::Isometry3d::Identity();
  imu_pose.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  f.sensor_frames["imu_link"] = imu_pose;
  const Eigen::Quaterniond level_from_base(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  const Eigen::Quaterniond level_from_imu = level_from_base * Eigen::Quaterniond(imu_pose.linear());
  auto m = zeroed<ros2::Imu>();
  m.header.stamp = {9, 0};
  std::strcpy(m.header.frame_id, "imu_link");
  m.orientation = {level_from_imu.x(), level_from_imu.y(), level_from_imu.z(), level_from_imu.w()};
  m.orientation_covariance[0] = m.orientation_covariance[4] = m.orientation_covariance[8] = 0.0004;
  m.angular_velocity = {0.1, 0.0, 0.2};          // in the imu frame
  m.linear_acceleration = {0.0, 0.0, 9.80665};  // at rest: gravity only
  const Imu imu = ros2::from_ros2(m, f);
  EXPECT_TRUE(imu.orientation.isApprox(level_from_base, 1e-9));
  EXPECT_TRUE(imu.angular_velocity.isApprox(imu_pose.linear() * Eigen::Vector3d(0.1, 0.0, 0.2), 1e-12));
  EXPECT_LT(imu.linear_acceleration.norm(), 1e-9);
  EXPECT_NEAR(imu.orientation_stddev, 0.02, 1e-12);

  m.orientation_covariance[0] = -1.0;
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m, f); }).find("this IMU gives no orientation"),
            std::string::npos);
}

TEST(Ros2Odometry, PoseAndTwist) {
  auto m = zeroed<ros2::Odometry>();
  m.header.stamp = {2, 0};
  std::strcpy(m.header.frame_id, "odom");
  std::strcpy(m.child_frame_id, "base_link");
  m.pose.pose.position = {1, 2, 0};
  m.pose.pose.orientation = {0, 0, std::sin(0.25), std::cos(0.25)};
  m.twist.twist.linear = {0.5, 0, 0};
  m.twist.twist.angular = {0, 0, 0.1};
  const Odometry o = ros2::from_ros2(m);
  EXPECT_EQ(o.header.frame_id, "odom");
  EXPECT_TRUE(o.pose.translation().isApprox(Eigen::Vector3d(1, 2, 0)));
  EXPECT_NEAR(Eigen::AngleAxisd(o.pose.linear()).angle(), 0.5, 1e-12);
  EXPECT_EQ(o.linear_velocity, Eigen::Vector3d(0.5, 0, 0));
  m.pose.pose.orientation = {0, 0, 0, 0};
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m); }).find("odometry: pose orientation is a zero quaternion"),
            std::string::npos);
}

TEST(Ros2InitialPose, OnlyInTheMapFrame) {
  auto m = zeroed<ros2::PoseWithCovarianceStamped>();
  m.header.stamp = {4, 0};
  std::strcpy(m.header.frame_id, "map");
  m.pose.pose.position = {3, 4, 0};
  m.pose.pose.orientation = {0, 0, 0, 1};
  m.pose.covariance[0] = m.pose.covariance[7] = 0.25;
  const PoseEstimate p = ros2::from_ros2(m, frames());
  EXPECT_TRUE(p.pose.translation().isApprox(Eigen::Vector3d(3, 4, 0)));
  EXPECT_EQ(p.covariance(1, 1), 0.25);
  std::strcpy(m.header.frame_id, "odom");
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m, frames()); })
                .find("initial pose: frame 'odom' is not the map frame 'map'"),
            std::string::npos);
}

TEST(Ros2InitialPose, AsAmclTakesIt) {
  // What `ros2 topic pub /initialpose ...` sends: no stamp, frame "/map"; AMCL accepts it (the
  // bridge then stamps it with the robot's newest stamp, tf2's "latest").
  auto m = zeroed<ros2::PoseWithCovarianceStamped>();
  std::strcpy(m.header.frame_id, "/map");
  m.pose.pose.position = {1, 2, 0};
  m.pose.pose.orientation = {0, 0, std::sin(0.2), std::cos(0.2)};
  const PoseEstimate p = ros2::from_ros2(m, frames());
  EXPECT_EQ(p.header.stamp_ns, 0);
  EXPECT_EQ(p.header.frame_id, "map");
  EXPECT_NEAR(Eigen::AngleAxisd(p.pose.linear()).angle(), 0.4, 1e-12);
  // What AMCL (nav2_util::validateMsg) refuses: no frame, a quaternion that is not a unit one,
  // a covariance with a NaN.
  std::strcpy(m.header.frame_id, "");
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m, frames()); }).find("header.frame_id is empty"),
            std::string::npos);
  std::strcpy(m.header.frame_id, "map");
  m.pose.pose.orientation = {0, 0, 0, 0.9};
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m, frames()); }).find("not a unit quaternion (|q|^2 = 0.81"),
            std::string::npos);
  m.pose.pose.orientation = {0, 0, 0, 1.00004};  // |q|^2 - 1 < 1e-4: accepted
  EXPECT_NO_THROW(ros2::from_ros2(m, frames()));
  m.pose.covariance[35] = std::nan("");
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m, frames()); }).find("covariance has a NaN"), std::string::npos);
}

// The writers, read back through a reader in the same process.
class Ros2Writers : public ::testing::Test {
 protected:
  template <typename T, typename Write, typename Check>
  void round_trip(Write write, Check check) {
    dds::Reader<T> reader(participant_, "rt/roundtrip/" + std::to_string(++topic_), dds::QosProfile::kRos2Default,
                          nullptr, 10);
    dds::Writer<T> writer(participant_, reader.topic(), dds::QosProfile::kRos2Default, 10);
    write(writer);
    size_t taken = 0;
    for (int i = 0; i < 200 && taken == 0; ++i) {
      taken = reader.take(check);
      if (taken == 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    EXPECT_EQ(taken, 1u);
  }
  dds::Participant participant_{kDomain};
  int topic_ = 0;
};

TEST_F(Ros2Writers, PointCloudMapReadsBack) {
  PointCloud cloud;
  cloud.points = {{1, 2, 3}, {-4, 5.5f, 0}};
  cloud.intensity = {7, 8};
  round_trip<ros2::PointCloud2>(
      [&](const auto& w) { ros2::write(w, 1'500'000'000, cloud, "map"); },
      [&](const ros2::PointCloud2& m) {
        ros2::Frames f;
        f.base_frame = "map";  // read back as if map were the sensor's frame
        const PointCloud back = ros2::from_ros2(m, f, Limits{});
        EXPECT_EQ(back.points, cloud.points);
        EXPECT_EQ(back.intensity, cloud.intensity);
        EXPECT_EQ(back.header.stamp_ns, 1'500'000'000);
        EXPECT_TRUE(m.is_dense);
      });
}

TEST_F(Ros2Writers, OccupancyGridScalesTheLayer) {
  GridLayer belief;
  belief.layer = "belief";
  belief.resolution = 0.5;
  belief.origin = {-2, 3};
  belief.width = 2;
  belief.height = 2;
  belief.cells = {0.0f, 2.0f, std::nanf(""), 8.0f};  // not probabilities: [0, 8] -> [0, 100]
  round_trip<ros2::OccupancyGrid>(
      [&](const auto& w) { ros2::write(w, 2'000'000'000, belief, "map"); },
      [&](const ros2::OccupancyGrid& m) {
        EXPECT_EQ(std::vector<int8_t>(m.data._buffer, m.data._buffer + m.data._length),
                  (std::vector<int8_t>{0, 25, -1, 100}));
        EXPECT_FLOAT_EQ(m.info.resolution, 0.5f);
        EXPECT_EQ(m.info.origin.position.x, -2);
        EXPECT_EQ(m.info.origin.position.y, 3);
        EXPECT_EQ(m.info.width, 2u);
        EXPECT_EQ(ros2::frame_id(m.header), "map");
      });
  GridLayer occupancy = belief;
  occupancy.cells = {0.0f, 0.5f, 1.0f, 0.254f};  // probabilities: x 100
  round_trip<ros2::OccupancyGrid>([&](const auto& w) { ros2::write(w, 2'000'000'000, occupancy, "map"); },
                                  [&](const ros2::OccupancyGrid& m) {
                                    EXPECT_EQ(std::vector<int8_t>(m.data._buffer, m.data._buffer + m.data._length),
                                              (std::vector<int8_t>{0, 50, 100, 25}));
                                  });
}

TEST_F(Ros2Writers, PoseArrayAndTransform) {
  std::vector<Particle2D> particles = {{1, 2, 0.5, 0.3}, {-1, 0, -3.0, 0.7}};
  round_trip<ros2::PoseArray>([&](const auto& w) { ros2::write(w, 3'000'000'000, particles, "map"); },
                              [&](const ros2::PoseArray& m) {
                                ASSERT_EQ(m.poses._length, 2u);
                                const auto& q = m.poses._buffer[1].orientation;
                                EXPECT_NEAR(2 * std::atan2(q.z, q.w), -3.0, 1e-12);
                                EXPECT_EQ(m.poses._buffer[0].position.y, 2);
                              });
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.5, -0.25, 0);
  round_trip<ros2::TFMessage>([&](const auto& w) { ros2::write(w, 4'000'000'001, "map", "odom", T); },
                              [&](const ros2::TFMessage& m) {
                                ASSERT_EQ(m.transforms._length, 1u);
                                const auto& t = m.transforms._buffer[0];
                                EXPECT_EQ(ros2::frame_id(t.header), "map");
                                EXPECT_EQ(dds::to_string(t.child_frame_id), "odom");
                                EXPECT_EQ(ros2::stamp_ns(t.header.stamp), 4'000'000'001);
                                EXPECT_EQ(t.transform.translation.y, -0.25);
                              });
}

TEST_F(Ros2Writers, ParticleCloudCarriesPosesAndWeights) {
  std::vector<Particle2D> particles = {{1, 2, 0.5, 0.3}, {-1, 0, -3.0, 0.7}};
  round_trip<ros2::ParticleCloud>([&](const auto& w) { ros2::write(w, 3'000'000'000, particles, "map"); },
                                  [&](const ros2::ParticleCloud& m) {
                                    EXPECT_EQ(ros2::frame_id(m.header), "map");
                                    ASSERT_EQ(m.particles._length, 2u);
                                    const auto& q = m.particles._buffer[1].pose.orientation;
                                    EXPECT_NEAR(2 * std::atan2(q.z, q.w), -3.0, 1e-12);
                                    EXPECT_EQ(m.particles._buffer[0].pose.position.y, 2);
                                    EXPECT_EQ(m.particles._buffer[0].weight, 0.3);
                                    EXPECT_EQ(m.particles._buffer[1].weight, 0.7);
                                  });
}

TEST_F(Ros2Writers, RosoutLineAndDiscoveryInfo) {
  const std::string long_text(5000, 'x');
  round_trip<ros2::Log>([&](const auto& w) { ros2::write(w, 5'000'000'000, 30, "robot1.locd", long_text); },
                        [&](const ros2::Log& m) {
                          EXPECT_EQ(m.level, 30);
                          EXPECT_EQ(dds::to_string(m.name), "robot1.locd");
                          EXPECT_EQ(dds::to_string(m.msg), long_text.substr(0, 4095));
                          EXPECT_EQ(ros2::stamp_ns(m.stamp), 5'000'000'000);
                        });
  ros2::GidBytes participant{}, reader{}, writer{};
  for (uint8_t i = 0; i < 16; ++i) participant[i] = i, reader[i] = static_cast<uint8_t>(100 + i), writer[i] = 200;
  const std::vector<ros2::NodeEntities> nodes = {{"/robot1", "locd", {reader}, {writer, participant}},
                                                 {"/", "locd_b", {}, {}}};
  round_trip<ros2::ParticipantEntitiesInfo>([&](const auto& w) { ros2::write(w, participant, nodes); },
                                            [&](const ros2::ParticipantEntitiesInfo& m) {
                                              EXPECT_EQ(m.gid.data[15], 15);
                                              ASSERT_EQ(m.node_entities_info_seq._length, 2u);
                                              const auto& a = m.node_entities_info_seq._buffer[0];
                                              EXPECT_EQ(dds::to_string(a.node_namespace), "/robot1");
                                              EXPECT_EQ(dds::to_string(a.node_name), "locd");
                                              ASSERT_EQ(a.reader_gid_seq._length, 1u);
                                              EXPECT_EQ(a.reader_gid_seq._buffer[0].data[3], 103);
                                              ASSERT_EQ(a.writer_gid_seq._length, 2u);
                                              EXPECT_EQ(a.writer_gid_seq._buffer[1].data[7], 7);
                                              EXPECT_EQ(m.node_entities_info_seq._buffer[1].writer_gid_seq._length, 0u);
                                            });
}

TEST(Ros2Transforms, ReadFromATfMessage) {
  auto t = zeroed<ros2::TransformStamped>();
  t.header.stamp = {0, 0};  // a static broadcaster may leave it unstamped
  std::strcpy(t.header.frame_id, "/base_link");
  std::strcpy(t.child_frame_id, "laser");
  t.transform.translation = {0.2, 0, 0.3};
  t.transform.rotation = {0, 0, std::sin(0.5), std::cos(0.5)};
  auto m = zeroed<ros2::TFMessage>();
  borrow(m.transforms, &t, 1);
  const auto transforms = ros2::from_ros2(m);
  ASSERT_EQ(transforms.size(), 1u);
  EXPECT_EQ(transforms[0].parent, "base_link");
  EXPECT_EQ(transforms[0].child, "laser");
  EXPECT_EQ(transforms[0].stamp_ns, 0);
  EXPECT_TRUE(transforms[0].parent_from_child.translation().isApprox(Eigen::Vector3d(0.2, 0, 0.3)));
  t.transform.rotation = {0, 0, 0, 0};
  EXPECT_NE(error_of<InputError>([&] { ros2::from_ros2(m); }).find("transform 'base_link' -> 'laser'"),
            std::string::npos);
}
