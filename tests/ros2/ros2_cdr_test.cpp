// The ROS 2 types of idl/ros2.idl serialize byte for byte as ROS 2 does: for each type locd reads
// or writes, Cyclone's serializer (dds_stream_write with the type's ops, XCDR1, as on the wire
// after the 4-byte encapsulation header) against CDR computed here field by field from the .msg
// definitions (little-endian; each primitive aligned to its size from the start of the payload;
// a string = uint32 length with the NUL, the characters, NUL; a sequence = uint32 count, items;
// a fixed array = its items). Header and Time are also spelled out byte by byte.
#include <gtest/gtest.h>

#include <dds/ddsi/ddsi_cdrstream.h>

#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "locd/dds/ros2.hpp"

namespace {

using namespace locd::dds;

template <typename T>
T zeroed() {
  T v;
  std::memset(&v, 0, sizeof(v));
  return v;
}

// What Cyclone puts after the encapsulation header for `sample`.
template <typename T>
std::vector<uint8_t> cyclone_cdr(const T& sample) {
  dds_ostream_t os;
  dds_ostream_init(&os, 0, 1);  // XCDR1
  dds_stream_write(&os, reinterpret_cast<const char*>(&sample), descriptor<T>().m_ops);
  std::vector<uint8_t> bytes(os.m_buffer, os.m_buffer + os.m_index);
  dds_ostream_fini(&os);
  return bytes;
}

// CDR (XCDR1, little-endian) written by hand, member by member.
class Cdr {
 public:
  template <typename V>
  Cdr& put(V value) {
    while (bytes_.size() % sizeof(V)) bytes_.push_back(0);
    uint8_t raw[sizeof(V)];
    std::memcpy(raw, &value, sizeof(V));  // the test host is little-endian (checked in each test)
    bytes_.insert(bytes_.end(), raw, raw + sizeof(V));
    return *this;
  }
  Cdr& text(const std::string& s) {
    put<uint32_t>(static_cast<uint32_t>(s.size() + 1));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
    bytes_.push_back(0);
    return *this;
  }
  Cdr& header(int32_t sec, uint32_t nanosec, const std::string& frame) { return put(sec).put(nanosec).text(frame); }
  Cdr& doubles(std::initializer_list<double> values) {
    for (double v : values) put(v);
    return *this;
  }
  Cdr& covariance(double first) {  // the 36 (or 9) entries first, first + 1, ...
    for (int k = 0; k < 36; ++k) put(first + k);
    return *this;
  }
  const std::vector<uint8_t>& bytes() const { return bytes_; }

 private:
  std::vector<uint8_t> bytes_;
};

bool little_endian_host() {
  const uint16_t one = 1;
  uint8_t first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

void set_header(std_msgs_msg_dds__Header_& h, int32_t sec, uint32_t nanosec, const char* frame) {
  h.stamp = {sec, nanosec};
  std::strcpy(h.frame_id, frame);
}

void fill_covariance(double (&c)[36], double first) {
  for (int k = 0; k < 36; ++k) c[k] = first + k;
}

template <typename Seq, typename Item>
void borrow(Seq& seq, Item* data, size_t n) {
  seq._buffer = data;
  seq._length = seq._maximum = static_cast<uint32_t>(n);
  seq._release = false;
}

class Ros2Cdr : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!little_endian_host()) GTEST_SKIP() << "the expected bytes are written little-endian";
  }
};

}  // namespace

TEST_F(Ros2Cdr, HeaderAndTimeByteByByte) {
  auto m = zeroed<ros2::PoseWithCovarianceStamped>();
  set_header(m.header, 1, 2, "map");
  const std::vector<uint8_t> cdr = cyclone_cdr(m);
  const std::vector<uint8_t> header = {0x01, 0, 0, 0,    // stamp.sec = 1 (int32)
                                       0x02, 0, 0, 0,    // stamp.nanosec = 2 (uint32)
                                       0x04, 0, 0, 0,    // frame_id: 4 bytes with the NUL
                                       'm', 'a', 'p', 0};
  ASSERT_GE(cdr.size(), header.size());
  EXPECT_EQ(std::vector<uint8_t>(cdr.begin(), cdr.begin() + 16), header);
  // Then position.x, a double at offset 16 (already aligned to 8).
  EXPECT_EQ(cdr.size(), 16u + 7 * 8 + 36 * 8);
}

TEST_F(Ros2Cdr, PoseWithCovarianceStamped) {
  auto m = zeroed<ros2::PoseWithCovarianceStamped>();
  set_header(m.header, 1700000000, 123456789, "odom");  // 5 bytes of text: the pose starts padded
  m.pose.pose.position = {1.5, -2.25, 0.125};
  m.pose.pose.orientation = {0.0, 0.0, 0.6, 0.8};
  fill_covariance(m.pose.covariance, 100.0);
  Cdr expected;
  expected.header(1700000000, 123456789, "odom").doubles({1.5, -2.25, 0.125, 0.0, 0.0, 0.6, 0.8}).covariance(100.0);
  EXPECT_EQ(cyclone_cdr(m), expected.bytes());
}

TEST_F(Ros2Cdr, PoseArray) {
  auto m = zeroed<ros2::PoseArray>();
  set_header(m.header, 5, 6, "map");
  geometry_msgs_msg_dds__Pose_ poses[2] = {{{1, 2, 3}, {0, 0, 0, 1}}, {{-1, -2, -3}, {0.5, 0.5, 0.5, 0.5}}};
  borrow(m.poses, poses, 2);
  Cdr expected;
  expected.header(5, 6, "map").put<uint32_t>(2).doubles({1, 2, 3, 0, 0, 0, 1}).doubles({-1, -2, -3, 0.5, 0.5, 0.5, 0.5});
  EXPECT_EQ(cyclone_cdr(m), expected.bytes());
}

TEST_F(Ros2Cdr, TFMessage) {
  auto m = zeroed<ros2::TFMessage>();
  auto t = zeroed<ros2::TransformStamped>();
  set_header(t.header, 7, 8, "map");
  std::strcpy(t.child_frame_id, "robot1/odom");
  t.transform.translation = {0.5, 0.25, 0.0};
  t.transform.rotation = {0.0, 0.0, 0.0, 1.0};
  borrow(m.transforms, &t, 1);
  Cdr expected;
  expected.put<uint32_t>(1).header(7, 8, "map").text("robot1/odom").doubles({0.5, 0.25, 0.0, 0.0, 0.0, 0.0, 1.0});
  EXPECT_EQ(cyclone_cdr(m), expected.bytes());
}

TEST_F(Ros2Cdr, LaserScan) {
  auto m = zeroed<ros2::LaserScan>();
  set_header(m.header, 10, 20, "laser");
  m.angle_min = -1.5f;
  m.angle_max = 1.5f;
  m.angle_increment = 0.75f;
  m.time_increment = 0.001f;
  m.scan_time = 0.04f;
  m.range_min = 0.05f;
  m.range_max = 30.0f;
  float ranges[5] = {1.0f, 2.0f, std::numeric_limits<float>::infinity(), 4.0f, 5.0f};
  float intensities[5] = {10, 20, 0, 40, 50};
  borrow(m.ranges, ranges, 5);
  borrow(m.intensities, intensities, 5);
  Cdr expected;
  expected.header(10, 20, "laser");
  for (float f : {-1.5f, 1.5f, 0.75f, 0.001f, 0.04f, 0.05f, 30.0f}) expected.put(f);
  expected.put<uint32_t>(5);
  for (float f : ranges) expected.put(f);
  expected.put<uint32_t>(5);
  for (float f : intensities) expected.put(f);
  EXPECT_EQ(cyclone_cdr(m), expected.bytes());
}

TEST_F(Ros2Cdr, PointCloud2AndPointField) {
  auto m = zeroed<ros2::PointCloud2>();
  set_header(m.header, 11, 12, "lidar");
  m.height = 1;
  m.width = 2;
  ros2::PointField fields[2];
  std::memset(fields, 0, sizeof fields);
  std::strcpy(fields[0].name, "x");
  fields[0].offset = 0;
  fields[0].datatype = ros2::kFloat32;
  fields[0].count = 1;
  std::strcpy(fields[1].name, "intensity");
  fields[1].offset = 4;
  fields[1].datatype = ros2::kUint8;
  fields[1].count = 1;
  borrow(m.fields, fields, 2);
  m.is_bigendian = false;
  m.point_step = 5;
  m.row_step = 10;
  uint8_t data[10] = {0, 0, 128, 63, 7, 0, 0, 0, 64, 9};
  borrow(m.data, data, 10);
  m.is_dense = true;
  Cdr expected;
  expected.header(11, 12, "lidar").put<uint32_t>(1).put<uint32_t>(2).put<uint32_t>(2);
  expected.text("x").put<uint32_t>(0).put<uint8_t>(ros2::kFloat32).put<uint32_t>(1);
  expected.text("intensity").put<uint32_t>(4).put<uint8_t>(ros2::kUint8).put<uint32_t>(1);
  expected.put<uint8_t>(0).put<uint32_t>(5).put<uint32_t>(10).put<uint32_t>(10);
  for (uint8_t b : data) expected.put(b);
  expected.put<uint8_t>(1);
  EXPECT_EQ(cyclone_cdr(m), expected.bytes());
}

TEST_F(Ros2Cdr, Image) {
  auto m = zeroed<ros2::Image>();
  set_header(m.header, 13, 14, "camera");
  m.height = 2;
  m.width = 3;
  std::strcpy(m.encoding, "rgb8");
  m.is_bigendian = 0;
  m.step = 9;
  uint8_t data[18];
  for (int i = 0; i < 18; ++i) data[i] = static_cast<uint8_t>(i * 13);
  borrow(m.data, data, 18);
  Cdr expected;
  expected.header(13, 14, "camera").put<uint32_t>(2).put<uint32_t>(3).text("rgb8").put<uint8_t>(0).put<uint32_t>(9);
  expected.put<uint32_t>(18);
  for (uint8_t b : data) expected.put(b);
  EXPECT_EQ(cyclone_cdr(m), expected.bytes());
}

TEST_F(Ros2Cdr, Imu) {
  auto m = zeroed<ros2::Imu>();
  set_header(m.header, 15, 16, "imu_link");
  m.orientation = {0.1, 0.2, 0.3, 0.9};
  m.angular_velocity = {0.01, 0.02, 0.03};
  m.linear_acceleration = {0.5, -0.5, 9.8};
  for (int k = 0; k < 9; ++k) {
    m.orientation_covariance[k] = k;
    m.angular_velocity_covariance[k] = 10 + k;
    m.linear_acceleration_covariance[k] = 20 + k;
  }
  Cdr expected;
  expected.header(15, 16, "imu_link").doubles({0.1, 0.2, 0.3, 0.9});
  for (int k = 0; k < 9; ++k) expected.put(static_cast<double>(k));
  expected.doubles({0.01, 0.02, 0.03});
  for (int k = 0; k < 9; ++k) expected.put(static_cast<double>(10 + k));
  expected.doubles({0.5, -0.5, 9.8});
  for (int k = 0; k < 9; ++k) expected.put(static_cast<double>(20 + k));
  EXPECT_EQ(cyclone_cdr(m), expected.bytes());
}

TEST_F(Ros2Cdr, Odometry) {
  auto m = zeroed<ros2::Odometry>();
  set_header(m.header, 17, 18, "odom");
  std::strcpy(m.child_frame_id, "base_link");
  m.pose.pose.position = {1, 2, 0};
  m.pose.pose.orientation = {0, 0, 0, 1};
  fill_covariance(m.pose.covariance, 1000.0);
  m.twist.twist.linear = {0.5, 0, 0};
  m.twist.twist.angular = {0, 0, 0.1};
  fill_covariance(m.twist.covariance, 2000.0);
  Cdr expected;
  expected.header(17, 18, "odom").text("base_link").doubles({1, 2, 0, 0, 0, 0, 1}).covariance(1000.0);
  expected.doubles({0.5, 0, 0, 0, 0, 0.1}).covariance(2000.0);
  EXPECT_EQ(cyclone_cdr(m), expected.bytes());
}

TEST_F(Ros2Cdr, OccupancyGridAndMapMetaData) {
  auto m = zeroed<ros2::OccupancyGrid>();
  set_header(m.header, 19, 20, "map");
  m.info.map_load_time = {21, 22};
  m.info.resolution = 0.05f;
  m.info.width = 3;
  m.info.height = 1;
  m.info.origin.position = {-10, -5, 0};
  m.info.origin.orientation = {0, 0, 0, 1};
  int8_t data[3] = {0, 100, -1};
  borrow(m.data, data, 3);
  Cdr expected;
  expected.header(19, 20, "map").put<int32_t>(21).put<uint32_t>(22).put(0.05f).put<uint32_t>(3).put<uint32_t>(1);
  expected.doubles({-10, -5, 0, 0, 0, 0, 1}).put<uint32_t>(3).put<int8_t>(0).put<int8_t>(100).put<int8_t>(-1);
  EXPECT_EQ(cyclone_cdr(m), expected.bytes());
}

TEST_F(Ros2Cdr, TypeNamesAreRos2s) {
  EXPECT_STREQ(descriptor<ros2::LaserScan>().m_typename, "sensor_msgs::msg::dds_::LaserScan_");
  EXPECT_STREQ(descriptor<ros2::PointCloud2>().m_typename, "sensor_msgs::msg::dds_::PointCloud2_");
  EXPECT_STREQ(descriptor<ros2::Image>().m_typename, "sensor_msgs::msg::dds_::Image_");
  EXPECT_STREQ(descriptor<ros2::Imu>().m_typename, "sensor_msgs::msg::dds_::Imu_");
  EXPECT_STREQ(descriptor<ros2::Odometry>().m_typename, "nav_msgs::msg::dds_::Odometry_");
  EXPECT_STREQ(descriptor<ros2::OccupancyGrid>().m_typename, "nav_msgs::msg::dds_::OccupancyGrid_");
  EXPECT_STREQ(descriptor<ros2::PoseWithCovarianceStamped>().m_typename,
               "geometry_msgs::msg::dds_::PoseWithCovarianceStamped_");
  EXPECT_STREQ(descriptor<ros2::PoseArray>().m_typename, "geometry_msgs::msg::dds_::PoseArray_");
  EXPECT_STREQ(descriptor<ros2::TFMessage>().m_typename, "tf2_msgs::msg::dds_::TFMessage_");
  // Keyless: ROS 2 topics have no instances.
  EXPECT_EQ(descriptor<ros2::PoseWithCovarianceStamped>().m_nkeys, 0u);
  EXPECT_EQ(descriptor<ros2::LaserScan>().m_nkeys, 0u);
  EXPECT_EQ(descriptor<ros2::TFMessage>().m_nkeys, 0u);
}
