#include "locd/dds/ros2_convert.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "locd/dds/convert.hpp"
#include "locd/sdk/validate.hpp"

namespace locd::dds::ros2 {
namespace {

constexpr int64_t kNanosecondsPerSecond = 1'000'000'000;
constexpr double kStandardGravity = 9.80665;  // m/s^2
constexpr double kUnitQuaternionTolerance = 1e-4;  // nav2_util::validateMsg's epsilon on |q|^2 - 1
constexpr size_t kMaxLogText = 4095;              // rcl_interfaces/Log.msg in idl/ros2.idl

template <typename Wire>
Wire zeroed() {
  Wire w;
  std::memset(&w, 0, sizeof(w));
  return w;
}

template <typename Seq, typename Item>
void borrow(Seq& seq, Item* data, size_t length) {
  seq._length = static_cast<uint32_t>(length);
  seq._maximum = static_cast<uint32_t>(length);
  seq._buffer = data;
  seq._release = false;
}

// A ROS 2 pose through locd's one pose check (finite, non-zero quaternion).
Eigen::Isometry3d isometry(const geometry_msgs_msg_dds__Pose_& p) {
  locd_msg_Pose3D wire{{p.position.x, p.position.y, p.position.z},
                       {p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w}};
  return dds::from_wire(wire);
}

void to_pose(const Eigen::Isometry3d& T, geometry_msgs_msg_dds__Pose_& out) {
  const Eigen::Quaterniond q(T.linear());
  out.position = {T.translation().x(), T.translation().y(), T.translation().z()};
  out.orientation = {q.x(), q.y(), q.z(), q.w()};
}

void to_header(int64_t stamp, const std::string& frame, Header& out) {
  out.stamp = to_time(stamp);
  copy_string(out.frame_id, frame);
}

locd::Header from_header(const Header& h) { return {stamp_ns(h.stamp), to_string(h.frame_id)}; }

std::string without_leading_slash(std::string frame) {
  if (!frame.empty() && frame.front() == '/') frame.erase(0, 1);
  return frame;
}

// ---------------------------------------------------------------- PointCloud2 fields

const char* datatype_name(uint8_t type) {
  static const char* const names[] = {"?", "INT8", "UINT8", "INT16", "UINT16", "INT32", "UINT32", "FLOAT32", "FLOAT64"};
  return type >= kInt8 && type <= kFloat64 ? names[type] : "unknown";
}

size_t datatype_size(uint8_t type) {
  switch (type) {
    case kInt8: case kUint8: return 1;
    case kInt16: case kUint16: return 2;
    case kInt32: case kUint32: case kFloat32: return 4;
    case kFloat64: return 8;
  }
  return 0;
}

using ReadValue = float (*)(const uint8_t*);

template <typename T, bool Swap>
float read_value(const uint8_t* p) {
  uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, p, sizeof(T));
  if constexpr (Swap) std::reverse(bytes, bytes + sizeof(T));
  T v;
  std::memcpy(&v, bytes, sizeof(T));
  return static_cast<float>(v);
}

template <bool Swap>
ReadValue reader_for(uint8_t type) {
  switch (type) {
    case kInt8: return &read_value<int8_t, Swap>;
    case kUint8: return &read_value<uint8_t, Swap>;
    case kInt16: return &read_value<int16_t, Swap>;
    case kUint16: return &read_value<uint16_t, Swap>;
    case kInt32: return &read_value<int32_t, Swap>;
    case kUint32: return &read_value<uint32_t, Swap>;
    case kFloat32: return &read_value<float, Swap>;
    case kFloat64: return &read_value<double, Swap>;
  }
  return nullptr;
}

bool host_is_big_endian() {
  const uint16_t one = 1;
  uint8_t first = 0;
  std::memcpy(&first, &one, 1);
  return first == 0;
}

struct FieldReader {
  uint32_t offset = 0;
  ReadValue read = nullptr;
};

// Checks every field of the cloud and returns the reader of `name` (read == nullptr: absent).
FieldReader field_reader(const PointCloud2& m, const char* name, bool coordinate) {
  const bool swap = static_cast<bool>(m.is_bigendian) != host_is_big_endian();
  for (uint32_t i = 0; i < m.fields._length; ++i) {
    const PointField& f = m.fields._buffer[i];
    if (to_string(f.name) != name) continue;
    if (coordinate && f.datatype != kFloat32 && f.datatype != kFloat64) {
      throw InputError(std::string("cloud: field '") + name + "' is " + datatype_name(f.datatype) + " (datatype " +
                       std::to_string(f.datatype) + "); x, y and z must be FLOAT32 (7) or FLOAT64 (8)");
    }
    if (f.count == 0) {
      throw InputError(std::string("cloud: field '") + name + "' has count 0; expected 1");
    }
    return {f.offset, swap ? reader_for<true>(f.datatype) : reader_for<false>(f.datatype)};
  }
  if (coordinate) throw InputError(std::string("cloud: no field '") + name + "'; a cloud needs x, y and z");
  return {};
}

void check_fields(const PointCloud2& m) {
  for (uint32_t i = 0; i < m.fields._length; ++i) {
    const PointField& f = m.fields._buffer[i];
    const size_t size = datatype_size(f.datatype);
    if (size == 0) {
      throw InputError("cloud: field '" + to_string(f.name) + "' has datatype " + std::to_string(f.datatype) +
                       ", which is no PointField type; allowed: 1 (INT8) to 8 (FLOAT64)");
    }
    const uint64_t end = static_cast<uint64_t>(f.offset) + size * std::max<uint32_t>(f.count, 1);
    if (end > m.point_step) {
      throw InputError("cloud: field '" + to_string(f.name) + "' (offset " + std::to_string(f.offset) + ", " +
                       datatype_name(f.datatype) + " x " + std::to_string(f.count) + ") ends at byte " +
                       std::to_string(end) + ", beyond point_step " + std::to_string(m.point_step));
    }
  }
}

}  // namespace

int64_t stamp_ns(const Time& t) {
  if (t.sec == 0 && t.nanosec == 0) {
    throw InputError("header.stamp is zero; a ROS 2 driver stamps each message with the time it was measured");
  }
  if (t.nanosec >= kNanosecondsPerSecond) {
    throw InputError("header.stamp.nanosec = " + std::to_string(t.nanosec) + " is not allowed; expected [0, 1e9)");
  }
  return static_cast<int64_t>(t.sec) * kNanosecondsPerSecond + static_cast<int64_t>(t.nanosec);
}

Time to_time(int64_t stamp) {
  int64_t sec = stamp / kNanosecondsPerSecond;
  int64_t nanosec = stamp % kNanosecondsPerSecond;
  if (nanosec < 0) {
    nanosec += kNanosecondsPerSecond;
    sec -= 1;
  }
  return {static_cast<int32_t>(sec), static_cast<uint32_t>(nanosec)};
}

Frames Frames::from(const Ros2Config& config, const FrameSource* tf) {
  return {config.map_frame, config.base_frame, config.sensor_frames, tf};
}

Eigen::Isometry3d Frames::sensor_pose(const std::string& frame_id, int64_t stamp) const {
  const std::string frame = without_leading_slash(frame_id);
  if (frame == base_frame) return Eigen::Isometry3d::Identity();
  const auto it = sensor_frames.find(frame);
  if (it != sensor_frames.end()) return it->second;
  if (sensor_frames.empty() && tf) return tf->pose_in(base_frame, frame, stamp);
  throw InputError("frame '" + frame + "' is neither the base frame '" + base_frame +
                   "' nor in ros2.sensor_frames; add '" + frame + ": [x, y, z, roll, pitch, yaw]' (its pose in " +
                   base_frame + ") to the robot's ros2.sensor_frames, or leave sensor_frames out to take frames "
                   "from /tf_static and /tf");
}

std::vector<StampedTransform> from_ros2(const TFMessage& m) {
  std::vector<StampedTransform> out;
  out.reserve(m.transforms._length);
  for (uint32_t i = 0; i < m.transforms._length; ++i) {
    const TransformStamped& t = m.transforms._buffer[i];
    StampedTransform s;
    s.stamp_ns = t.header.stamp.sec == 0 && t.header.stamp.nanosec == 0 ? 0 : stamp_ns(t.header.stamp);
    s.parent = without_leading_slash(to_string(t.header.frame_id));
    s.child = without_leading_slash(to_string(t.child_frame_id));
    if (s.parent.empty() || s.child.empty()) throw InputError("transform " + std::to_string(i) + ": an empty frame id");
    const auto& p = t.transform.translation;
    const auto& r = t.transform.rotation;
    const geometry_msgs_msg_dds__Pose_ pose{{p.x, p.y, p.z}, {r.x, r.y, r.z, r.w}};
    try {
      s.parent_from_child = isometry(pose);
    } catch (const InputError& e) {
      throw InputError("transform '" + s.parent + "' -> '" + s.child + "': " + e.what());
    }
    out.push_back(std::move(s));
  }
  return out;
}

std::string frame_id(const Header& h) { return to_string(h.frame_id); }
std::string child_frame_id(const ros2::Odometry& m) { return to_string(m.child_frame_id); }

locd::LaserScan from_ros2(const ros2::LaserScan& m, const Frames& frames, const Limits& limits) {
  check_limit("scan", "beams", m.ranges._length, limits.max_scan_beams, "max_scan_beams");
  check_limit("scan", "intensities", m.intensities._length, limits.max_scan_beams, "max_scan_beams");
  if (m.intensities._length != 0 && m.intensities._length != m.ranges._length) {
    throw InputError("scan: " + std::to_string(m.intensities._length) + " intensities for " +
                     std::to_string(m.ranges._length) + " ranges; send none or one per range");
  }
  locd::LaserScan s;
  s.header = from_header(m.header);
  s.sensor_pose = frames.sensor_pose(s.header.frame_id, s.header.stamp_ns);
  s.angle_min = m.angle_min;
  s.angle_increment = m.angle_increment;
  s.range_min = m.range_min;
  s.range_max = m.range_max;
  s.ranges.assign(m.ranges._buffer, m.ranges._buffer + m.ranges._length);
  s.intensities.assign(m.intensities._buffer, m.intensities._buffer + m.intensities._length);
  validate(s);
  return s;
}

locd::PointCloud from_ros2(const PointCloud2& m, const Frames& frames, const Limits& limits) {
  const uint64_t n = static_cast<uint64_t>(m.width) * m.height;
  check_limit("cloud", "points", n, limits.max_cloud_points, "max_cloud_points");
  check_fields(m);
  const FieldReader x = field_reader(m, "x", true);
  const FieldReader y = field_reader(m, "y", true);
  const FieldReader z = field_reader(m, "z", true);
  const FieldReader intensity = field_reader(m, "intensity", false);
  const uint64_t row_bytes = static_cast<uint64_t>(m.width) * m.point_step;
  if (m.row_step < row_bytes) {
    throw InputError("cloud: row_step " + std::to_string(m.row_step) + " is shorter than width * point_step = " +
                     std::to_string(m.width) + " * " + std::to_string(m.point_step) + " = " + std::to_string(row_bytes));
  }
  const uint64_t expected = static_cast<uint64_t>(m.row_step) * m.height;
  if (m.data._length != expected) {
    throw InputError("cloud: data has " + std::to_string(m.data._length) + " bytes; expected row_step * height = " +
                     std::to_string(m.row_step) + " * " + std::to_string(m.height) + " = " + std::to_string(expected) +
                     " (width " + std::to_string(m.width) + ", point_step " + std::to_string(m.point_step) + ")");
  }
  locd::PointCloud c;
  c.header = from_header(m.header);
  c.sensor_pose = frames.sensor_pose(c.header.frame_id, c.header.stamp_ns);
  c.points.reserve(n);
  if (intensity.read) c.intensity.reserve(n);
  for (uint32_t row = 0; row < m.height; ++row) {
    const uint8_t* row_data = m.data._buffer + static_cast<size_t>(row) * m.row_step;
    for (uint32_t col = 0; col < m.width; ++col) {
      const uint8_t* point = row_data + static_cast<size_t>(col) * m.point_step;
      const Eigen::Vector3f p(x.read(point + x.offset), y.read(point + y.offset), z.read(point + z.offset));
      if (!p.allFinite()) continue;  // is_dense false: an invalid point is no return
      c.points.push_back(p);
      if (intensity.read) c.intensity.push_back(intensity.read(point + intensity.offset));
    }
  }
  if (n > 0 && c.points.empty()) throw InputError("cloud: every point is NaN or infinite");
  validate(c);
  return c;
}

locd::Image from_ros2(const ros2::Image& m, const Limits& limits) {
  const std::string encoding = to_string(m.encoding);
  int in_channels = 0;
  bool swap_red_blue = false;
  if (encoding == "mono8") in_channels = 1;
  else if (encoding == "bgr8") in_channels = 3;
  else if (encoding == "rgb8") in_channels = 3, swap_red_blue = true;
  else if (encoding == "bgra8") in_channels = 4;
  else if (encoding == "rgba8") in_channels = 4, swap_red_blue = true;
  else throw InputError("image: encoding '" + encoding + "' is not supported; allowed: mono8, bgr8, rgb8, bgra8, rgba8");
  check_limit("image", "pixels", static_cast<size_t>(m.width) * m.height, limits.max_image_pixels, "max_image_pixels");
  const size_t row = static_cast<size_t>(m.width) * in_channels;
  if (m.step < row) {
    throw InputError("image: step " + std::to_string(m.step) + " is shorter than a row of " + encoding + " (" +
                     std::to_string(row) + " bytes)");
  }
  const uint64_t expected = static_cast<uint64_t>(m.step) * m.height;
  if (m.data._length != expected) {
    throw InputError("image: " + std::to_string(m.data._length) + " bytes of data, expected step * height = " +
                     std::to_string(expected));
  }
  locd::Image img;
  img.header = from_header(m.header);
  img.width = static_cast<int>(m.width);
  img.height = static_cast<int>(m.height);
  img.channels = in_channels == 1 ? 1 : 3;
  img.data.resize(static_cast<size_t>(m.width) * m.height * img.channels);
  for (uint32_t r = 0; r < m.height; ++r) {
    const uint8_t* in = m.data._buffer + static_cast<size_t>(r) * m.step;
    uint8_t* out = img.data.data() + static_cast<size_t>(r) * m.width * img.channels;
    if (in_channels == 1) {
      std::memcpy(out, in, m.width);
      continue;
    }
    for (uint32_t c = 0; c < m.width; ++c, in += in_channels, out += 3) {
      out[0] = swap_red_blue ? in[2] : in[0];
      out[1] = in[1];
      out[2] = swap_red_blue ? in[0] : in[2];
    }
  }
  validate(img);
  return img;
}

locd::Imu from_ros2(const ros2::Imu& m, const Frames& frames) {
  if (m.orientation_covariance[0] == -1.0) {
    throw InputError("imu: orientation_covariance[0] = -1: this IMU gives no orientation; locd needs an attitude "
                     "(AHRS) IMU");
  }
  locd::Imu o;
  o.header = from_header(m.header);
  const Eigen::Isometry3d base_from_imu = frames.sensor_pose(o.header.frame_id, o.header.stamp_ns);
  const Eigen::Quaterniond level_from_imu(m.orientation.w, m.orientation.x, m.orientation.y, m.orientation.z);
  if (!level_from_imu.coeffs().allFinite() || level_from_imu.norm() < 1e-6) {
    throw InputError("imu: orientation is not a finite, non-zero quaternion");
  }
  const Eigen::Matrix3d R_base_imu = base_from_imu.linear();
  o.orientation = Eigen::Quaterniond(level_from_imu.normalized().toRotationMatrix() * R_base_imu.transpose());
  o.angular_velocity = R_base_imu * Eigen::Vector3d(m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z);
  if (m.linear_acceleration_covariance[0] != -1.0) {
    const Eigen::Vector3d measured =
        R_base_imu * Eigen::Vector3d(m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z);
    o.linear_acceleration = measured - o.orientation.conjugate() * Eigen::Vector3d(0.0, 0.0, kStandardGravity);
  }
  auto stddev = [](const double (&covariance)[9]) {
    const double largest = std::max({covariance[0], covariance[4], covariance[8]});
    return largest > 0.0 && std::isfinite(largest) ? std::sqrt(largest) : -1.0;
  };
  o.orientation_stddev = stddev(m.orientation_covariance);
  o.acceleration_stddev = m.linear_acceleration_covariance[0] == -1.0 ? -1.0 : stddev(m.linear_acceleration_covariance);
  validate(o);
  o.orientation.normalize();
  return o;
}

locd::Odometry from_ros2(const ros2::Odometry& m) {
  locd::Odometry o;
  o.header = from_header(m.header);
  try {
    o.pose = isometry(m.pose.pose);
  } catch (const InputError& e) {
    throw InputError(std::string("odometry: ") + e.what());
  }
  const auto& t = m.twist.twist;
  o.linear_velocity = {t.linear.x, t.linear.y, t.linear.z};
  o.angular_velocity = {t.angular.x, t.angular.y, t.angular.z};
  validate(o);
  return o;
}

locd::PoseEstimate from_ros2(const PoseWithCovarianceStamped& m, const Frames& frames) {
  locd::PoseEstimate p;
  const bool unstamped = m.header.stamp.sec == 0 && m.header.stamp.nanosec == 0;
  p.header.stamp_ns = unstamped ? 0 : stamp_ns(m.header.stamp);
  p.header.frame_id = without_leading_slash(to_string(m.header.frame_id));
  if (p.header.frame_id.empty()) {
    throw InputError("initial pose: header.frame_id is empty; expected the map frame '" + frames.map_frame + "'");
  }
  if (p.header.frame_id != frames.map_frame) {
    throw InputError("initial pose: frame '" + p.header.frame_id + "' is not the map frame '" + frames.map_frame +
                     "' (ros2.map_frame); an initial pose must be in the map frame, as AMCL's");
  }
  const auto& q = m.pose.pose.orientation;
  const double norm2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
  if (std::isfinite(norm2) && std::abs(norm2 - 1.0) >= kUnitQuaternionTolerance) {
    throw InputError("initial pose: orientation is not a unit quaternion (|q|^2 = " + std::to_string(norm2) +
                     "); AMCL refuses it too");
  }
  try {
    p.pose = isometry(m.pose.pose);
  } catch (const InputError& e) {
    throw InputError(std::string("initial pose: ") + e.what());
  }
  for (int k = 0; k < 36; ++k) {
    if (!std::isfinite(m.pose.covariance[k])) throw InputError("initial pose: covariance has a NaN or infinite entry");
    p.covariance(k / 6, k % 6) = m.pose.covariance[k];
  }
  return p;
}

// ------------------------------------------------------------------------ writing

void write(const Writer<PoseWithCovarianceStamped>& w, const locd::PoseEstimate& pose, const std::string& frame) {
  auto s = zeroed<PoseWithCovarianceStamped>();
  to_header(pose.header.stamp_ns, frame, s.header);
  to_pose(pose.pose, s.pose.pose);
  for (int k = 0; k < 36; ++k) s.pose.covariance[k] = pose.covariance(k / 6, k % 6);
  w.write(s);
}

void write(const Writer<TFMessage>& w, int64_t stamp, const std::string& parent, const std::string& child,
           const Eigen::Isometry3d& parent_from_child) {
  auto t = zeroed<TransformStamped>();
  to_header(stamp, parent, t.header);
  copy_string(t.child_frame_id, child);
  const Eigen::Quaterniond q(parent_from_child.linear());
  const Eigen::Vector3d& p = parent_from_child.translation();
  t.transform.translation = {p.x(), p.y(), p.z()};
  t.transform.rotation = {q.x(), q.y(), q.z(), q.w()};
  auto s = zeroed<TFMessage>();
  borrow(s.transforms, &t, 1);
  w.write(s);
}

void write(const Writer<OccupancyGrid>& w, int64_t stamp, const locd::GridLayer& grid, const std::string& frame) {
  auto s = zeroed<OccupancyGrid>();
  to_header(stamp, frame, s.header);
  s.info.map_load_time = to_time(stamp);
  s.info.resolution = static_cast<float>(grid.resolution);
  s.info.width = static_cast<uint32_t>(grid.width);
  s.info.height = static_cast<uint32_t>(grid.height);
  s.info.origin.position = {grid.origin.x(), grid.origin.y(), 0.0};
  s.info.origin.orientation = {0.0, 0.0, 0.0, 1.0};
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (float v : grid.cells) {
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  }
  const bool probabilities = lo >= 0.0f && hi <= 1.0f;
  const float offset = probabilities ? 0.0f : lo;
  const float scale = probabilities ? 100.0f : (hi > lo ? 100.0f / (hi - lo) : 0.0f);
  std::vector<int8_t> data(grid.cells.size());
  for (size_t i = 0; i < data.size(); ++i) {
    const float v = grid.cells[i];
    data[i] = std::isfinite(v) ? static_cast<int8_t>(std::lround(std::clamp((v - offset) * scale, 0.0f, 100.0f))) : -1;
  }
  borrow(s.data, data.data(), data.size());
  w.write(s);
}

void write(const Writer<PointCloud2>& w, int64_t stamp, const locd::PointCloud& cloud, const std::string& frame) {
  const bool with_intensity = !cloud.intensity.empty() && cloud.intensity.size() == cloud.points.size();
  PointField fields[4];
  std::memset(fields, 0, sizeof fields);
  const char* names[] = {"x", "y", "z", "intensity"};
  const uint32_t field_count = with_intensity ? 4 : 3;
  for (uint32_t i = 0; i < field_count; ++i) {
    copy_string(fields[i].name, names[i]);
    fields[i].offset = 4 * i;
    fields[i].datatype = kFloat32;
    fields[i].count = 1;
  }
  const uint32_t point_step = 4 * field_count;
  std::vector<uint8_t> data(static_cast<size_t>(point_step) * cloud.points.size());
  bool dense = true;
  for (size_t i = 0; i < cloud.points.size(); ++i) {
    float values[4] = {cloud.points[i].x(), cloud.points[i].y(), cloud.points[i].z(),
                       with_intensity ? cloud.intensity[i] : 0.0f};
    dense = dense && cloud.points[i].allFinite();
    std::memcpy(data.data() + i * point_step, values, point_step);  // host byte order, as is_bigendian says
  }
  auto s = zeroed<PointCloud2>();
  to_header(stamp, frame, s.header);
  s.height = 1;
  s.width = static_cast<uint32_t>(cloud.points.size());
  borrow(s.fields, fields, field_count);
  s.is_bigendian = host_is_big_endian();
  s.point_step = point_step;
  s.row_step = point_step * s.width;
  borrow(s.data, data.data(), data.size());
  s.is_dense = dense;
  w.write(s);
}

void write(const Writer<PoseArray>& w, int64_t stamp, const std::vector<locd::Particle2D>& particles,
           const std::string& frame) {
  std::vector<geometry_msgs_msg_dds__Pose_> poses(particles.size());
  for (size_t i = 0; i < particles.size(); ++i) {
    const auto& p = particles[i];
    poses[i].position = {p.x, p.y, 0.0};
    poses[i].orientation = {0.0, 0.0, std::sin(p.yaw / 2), std::cos(p.yaw / 2)};
  }
  auto s = zeroed<PoseArray>();
  to_header(stamp, frame, s.header);
  borrow(s.poses, poses.data(), poses.size());
  w.write(s);
}

void write(const Writer<ParticleCloud>& w, int64_t stamp, const std::vector<locd::Particle2D>& particles,
           const std::string& frame) {
  std::vector<Particle> out(particles.size());
  for (size_t i = 0; i < particles.size(); ++i) {
    const auto& p = particles[i];
    out[i].pose.position = {p.x, p.y, 0.0};
    out[i].pose.orientation = {0.0, 0.0, std::sin(p.yaw / 2), std::cos(p.yaw / 2)};
    out[i].weight = p.weight;
  }
  auto s = zeroed<ParticleCloud>();
  to_header(stamp, frame, s.header);
  borrow(s.particles, out.data(), out.size());
  w.write(s);
}

void write(const Writer<Log>& w, int64_t stamp, uint8_t level, const std::string& name, const std::string& text) {
  auto s = zeroed<Log>();
  s.stamp = to_time(stamp);
  s.level = level;
  copy_string(s.name, name.substr(0, sizeof(s.name) - 1));
  copy_string(s.msg, text.substr(0, kMaxLogText));
  w.write(s);
}

void write(const Writer<ParticipantEntitiesInfo>& w, const GidBytes& participant, const std::vector<NodeEntities>& nodes) {
  auto gids = [](const std::vector<GidBytes>& from, std::vector<Gid>& to) {
    to.resize(from.size());
    for (size_t i = 0; i < from.size(); ++i) std::copy(from[i].begin(), from[i].end(), to[i].data);
  };
  std::vector<std::vector<Gid>> readers(nodes.size()), writers(nodes.size());
  std::vector<NodeEntitiesInfo> infos(nodes.size());
  for (size_t i = 0; i < nodes.size(); ++i) {
    std::memset(&infos[i], 0, sizeof(infos[i]));
    copy_string(infos[i].node_namespace, nodes[i].node_namespace);
    copy_string(infos[i].node_name, nodes[i].node_name);
    gids(nodes[i].readers, readers[i]);
    gids(nodes[i].writers, writers[i]);
    borrow(infos[i].reader_gid_seq, readers[i].data(), readers[i].size());
    borrow(infos[i].writer_gid_seq, writers[i].data(), writers[i].size());
  }
  auto s = zeroed<ParticipantEntitiesInfo>();
  std::copy(participant.begin(), participant.end(), s.gid.data);
  borrow(s.node_entities_info_seq, infos.data(), infos.size());
  w.write(s);
}

void write(const Writer<ros2::LaserScan>& w, const locd::LaserScan& scan) {
  auto s = zeroed<ros2::LaserScan>();
  to_header(scan.header.stamp_ns, scan.header.frame_id, s.header);
  s.angle_min = scan.angle_min;
  s.angle_increment = scan.angle_increment;
  s.angle_max = scan.ranges.empty() ? scan.angle_min
                                    : static_cast<float>(scan.angle(scan.ranges.size() - 1));
  s.range_min = scan.range_min;
  s.range_max = scan.range_max;
  borrow(s.ranges, const_cast<float*>(scan.ranges.data()), scan.ranges.size());
  borrow(s.intensities, const_cast<float*>(scan.intensities.data()), scan.intensities.size());
  w.write(s);
}

void write(const Writer<ros2::Odometry>& w, const locd::Odometry& odometry, const std::string& child) {
  auto s = zeroed<ros2::Odometry>();
  to_header(odometry.header.stamp_ns, odometry.header.frame_id, s.header);
  copy_string(s.child_frame_id, child);
  to_pose(odometry.pose, s.pose.pose);
  const auto& v = odometry.linear_velocity;
  const auto& a = odometry.angular_velocity;
  s.twist.twist.linear = {v.x(), v.y(), v.z()};
  s.twist.twist.angular = {a.x(), a.y(), a.z()};
  w.write(s);
}

}  // namespace locd::dds::ros2
