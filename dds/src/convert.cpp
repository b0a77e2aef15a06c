#include "locd/dds/convert.hpp"

#include <cmath>
#include <cstring>

#include "locd/sdk/validate.hpp"

namespace locd::dds {
namespace {

template <typename Seq>
void borrow(Seq& seq, const void* data, size_t length) {
  seq._length = static_cast<uint32_t>(length);
  seq._maximum = static_cast<uint32_t>(length);
  seq._buffer = static_cast<decltype(seq._buffer)>(const_cast<void*>(data));
  seq._release = false;
}

bool finite(const locd_msg_Vector3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

Eigen::Vector3d vec(const locd_msg_Vector3& v) { return {v.x, v.y, v.z}; }
void vec(const Eigen::Vector3d& v, locd_msg_Vector3& out) { out = {v.x(), v.y(), v.z()}; }

template <typename Wire>
Wire zeroed() {
  Wire w;
  std::memset(&w, 0, sizeof(w));
  return w;
}

}  // namespace

Header from_wire(const locd_msg_MessageHeader& h) { return {h.stamp_ns, to_string(h.frame_id), h.sequence_number}; }

void to_wire(const Header& h, locd_msg_MessageHeader& out) {
  out.stamp_ns = h.stamp_ns;
  copy_string(out.frame_id, h.frame_id);
  out.sequence_number = h.sequence;
}

Eigen::Isometry3d from_wire(const locd_msg_Pose3D& p) {
  const auto& q = p.orientation;
  if (!finite(p.position) || !std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) || !std::isfinite(q.w)) {
    throw InputError("pose has a NaN or infinite component");
  }
  Eigen::Quaterniond quat(q.w, q.x, q.y, q.z);
  if (quat.norm() < 1e-6) throw InputError("pose orientation is a zero quaternion");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = quat.normalized().toRotationMatrix();
  T.translation() = vec(p.position);
  return T;
}

void to_wire(const Eigen::Isometry3d& T, locd_msg_Pose3D& out) {
  vec(T.translation(), out.position);
  const Eigen::Quaterniond q(T.linear());
  out.orientation = {q.x(), q.y(), q.z(), q.w()};
}

Odometry from_wire(const locd_msg_Odometry& m) {
  Odometry o;
  o.header = from_wire(m.header);
  try {
    o.pose = from_wire(m.pose);
  } catch (const InputError& e) {
    throw InputError(std::string("odometry: ") + e.what());
  }
  o.linear_velocity = vec(m.linear_velocity);
  o.angular_velocity = vec(m.angular_velocity);
  validate(o);
  return o;
}

Imu from_wire(const locd_msg_Imu& m) {
  Imu o;
  o.header = from_wire(m.header);
  const auto& q = m.orientation;
  o.orientation = Eigen::Quaterniond(q.w, q.x, q.y, q.z);
  o.angular_velocity = vec(m.angular_velocity);
  o.linear_acceleration = vec(m.linear_acceleration);
  o.orientation_stddev = m.orientation_stddev;
  o.acceleration_stddev = m.acceleration_stddev;
  validate(o);
  o.orientation.normalize();
  return o;
}

LaserScan from_wire(const locd_msg_LaserScan& m, const Limits& limits) {
  check_limit("scan", "beams", m.ranges._length, limits.max_scan_beams, "max_scan_beams");
  check_limit("scan", "intensities", m.intensities._length, limits.max_scan_beams, "max_scan_beams");
  LaserScan s;
  s.header = from_wire(m.header);
  try {
    s.sensor_pose = from_wire(m.sensor_pose);
  } catch (const InputError& e) {
    throw InputError(std::string("scan sensor_pose: ") + e.what());
  }
  s.angle_min = m.angle_min;
  s.angle_increment = m.angle_increment;
  s.range_min = m.range_min;
  s.range_max = m.range_max;
  s.ranges.assign(m.ranges._buffer, m.ranges._buffer + m.ranges._length);
  s.intensities.assign(m.intensities._buffer, m.intensities._buffer + m.intensities._length);
  validate(s);
  return s;
}

PointCloud from_wire(const locd_msg_PointCloud& m, const Limits& limits) {
  if (m.xyz._length % 3 != 0) throw InputError("cloud: xyz length " + std::to_string(m.xyz._length) + " is not a multiple of 3");
  const size_t n = m.xyz._length / 3;
  check_limit("cloud", "points", n, limits.max_cloud_points, "max_cloud_points");
  if (m.intensity._length != 0 && m.intensity._length != n) {
    throw InputError("cloud: " + std::to_string(m.intensity._length) + " intensities for " + std::to_string(n) +
                     " points; send none or one per point");
  }
  PointCloud c;
  c.header = from_wire(m.header);
  try {
    c.sensor_pose = from_wire(m.sensor_pose);
  } catch (const InputError& e) {
    throw InputError(std::string("cloud sensor_pose: ") + e.what());
  }
  c.points.reserve(n);
  c.intensity.reserve(m.intensity._length);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f p(m.xyz._buffer[3 * i], m.xyz._buffer[3 * i + 1], m.xyz._buffer[3 * i + 2]);
    if (!p.allFinite()) continue;  // NaN points are "no return", dropped here
    c.points.push_back(p);
    if (m.intensity._length) c.intensity.push_back(m.intensity._buffer[i]);
  }
  if (n > 0 && c.points.empty()) throw InputError("cloud: every point is NaN or infinite");
  validate(c);
  return c;
}

Image from_wire(const locd_msg_Image& m, const Limits& limits) {
  const std::string encoding = to_string(m.encoding);
  int channels = 0;
  if (encoding == "mono8") channels = 1;
  else if (encoding == "bgr8") channels = 3;
  else throw InputError("image: encoding '" + encoding + "' is not supported; allowed: mono8, bgr8");
  check_limit("image", "pixels", static_cast<size_t>(m.width) * m.height, limits.max_image_pixels, "max_image_pixels");
  const size_t row = static_cast<size_t>(m.width) * channels;
  if (m.step < row) throw InputError("image: step " + std::to_string(m.step) + " is shorter than a row (" + std::to_string(row) + " bytes)");
  if (m.data._length != static_cast<size_t>(m.step) * m.height) {
    throw InputError("image: " + std::to_string(m.data._length) + " bytes of data, expected step * height = " +
                     std::to_string(static_cast<size_t>(m.step) * m.height));
  }
  Image img;
  img.header = from_wire(m.header);
  img.width = static_cast<int>(m.width);
  img.height = static_cast<int>(m.height);
  img.channels = channels;
  img.data.resize(row * m.height);
  for (uint32_t r = 0; r < m.height; ++r) {
    std::memcpy(img.data.data() + r * row, m.data._buffer + static_cast<size_t>(r) * m.step, row);
  }
  validate(img);
  return img;
}

LandmarkDetections from_wire(const locd_msg_LandmarkDetections& m, const Limits& limits) {
  check_limit("detections", "detections", m.detections._length, limits.max_detections, "max_detections");
  LandmarkDetections out;
  out.header = from_wire(m.header);
  out.detections.reserve(m.detections._length);
  for (uint32_t i = 0; i < m.detections._length; ++i) {
    const auto& d = m.detections._buffer[i];
    LandmarkDetection det;
    det.class_label = to_string(d.class_label);
    det.position = vec(d.position);
    for (int k = 0; k < 9; ++k) det.covariance(k / 3, k % 3) = d.covariance[k];
    out.detections.push_back(std::move(det));
  }
  validate(out);
  return out;
}

PoseEstimate from_wire(const locd_msg_PoseEstimate& m) {
  PoseEstimate p;
  p.header = from_wire(m.header);
  p.pose = from_wire(m.pose);
  for (int k = 0; k < 36; ++k) p.covariance(k / 6, k % 6) = m.covariance[k];
  p.linear_velocity = vec(m.linear_velocity);
  return p;
}

PoseEstimate from_wire(const locd_msg_InitialPose& m) {
  PoseEstimate p;
  p.header = from_wire(m.header);
  p.pose = from_wire(m.pose);
  for (int k = 0; k < 36; ++k) {
    if (!std::isfinite(m.covariance[k])) throw InputError("initial pose: covariance has a NaN or infinite entry");
    p.covariance(k / 6, k % 6) = m.covariance[k];
  }
  return p;
}

ExplorationGoal from_wire(const locd_msg_ExplorationGoal& m) {
  ExplorationGoal g;
  g.header = from_wire(m.header);
  g.pose = from_wire(m.pose);
  if (!std::isfinite(m.score)) throw InputError("exploration goal: score is NaN or infinite");
  g.score = m.score;
  g.done = m.done;
  return g;
}

// ------------------------------------------------------------------------------- writers

void to_wire(const std::string& robot_id, const Odometry& m, const WireUse<locd_msg_Odometry>& use) {
  auto s = zeroed<locd_msg_Odometry>();
  copy_string(s.robot_id, robot_id);
  to_wire(m.header, s.header);
  to_wire(m.pose, s.pose);
  vec(m.linear_velocity, s.linear_velocity);
  vec(m.angular_velocity, s.angular_velocity);
  use(s);
}

void write(const Writer<locd_msg_Odometry>& w, const std::string& robot_id, const Odometry& m) {
  to_wire(robot_id, m, [&](const locd_msg_Odometry& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const Imu& m, const WireUse<locd_msg_Imu>& use) {
  auto s = zeroed<locd_msg_Imu>();
  copy_string(s.robot_id, robot_id);
  to_wire(m.header, s.header);
  s.orientation = {m.orientation.x(), m.orientation.y(), m.orientation.z(), m.orientation.w()};
  vec(m.angular_velocity, s.angular_velocity);
  vec(m.linear_acceleration, s.linear_acceleration);
  s.orientation_stddev = m.orientation_stddev;
  s.acceleration_stddev = m.acceleration_stddev;
  use(s);
}

void write(const Writer<locd_msg_Imu>& w, const std::string& robot_id, const Imu& m) {
  to_wire(robot_id, m, [&](const locd_msg_Imu& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const LaserScan& m, const WireUse<locd_msg_LaserScan>& use) {
  auto s = zeroed<locd_msg_LaserScan>();
  copy_string(s.robot_id, robot_id);
  to_wire(m.header, s.header);
  to_wire(m.sensor_pose, s.sensor_pose);
  s.angle_min = m.angle_min;
  s.angle_increment = m.angle_increment;
  s.range_min = m.range_min;
  s.range_max = m.range_max;
  borrow(s.ranges, m.ranges.data(), m.ranges.size());
  borrow(s.intensities, m.intensities.data(), m.intensities.size());
  use(s);
}

void write(const Writer<locd_msg_LaserScan>& w, const std::string& robot_id, const LaserScan& m) {
  to_wire(robot_id, m, [&](const locd_msg_LaserScan& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const PointCloud& m, const WireUse<locd_msg_PointCloud>& use) {
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "Vector3f must be three packed floats");
  auto s = zeroed<locd_msg_PointCloud>();
  copy_string(s.robot_id, robot_id);
  to_wire(m.header, s.header);
  to_wire(m.sensor_pose, s.sensor_pose);
  borrow(s.xyz, m.points.data(), 3 * m.points.size());
  borrow(s.intensity, m.intensity.data(), m.intensity.size());
  use(s);
}

void write(const Writer<locd_msg_PointCloud>& w, const std::string& robot_id, const PointCloud& m) {
  to_wire(robot_id, m, [&](const locd_msg_PointCloud& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const Image& m, const WireUse<locd_msg_Image>& use) {
  auto s = zeroed<locd_msg_Image>();
  copy_string(s.robot_id, robot_id);
  to_wire(m.header, s.header);
  s.width = static_cast<uint32_t>(m.width);
  s.height = static_cast<uint32_t>(m.height);
  copy_string(s.encoding, m.channels == 3 ? "bgr8" : "mono8");
  s.step = static_cast<uint32_t>(m.width * m.channels);
  borrow(s.data, m.data.data(), m.data.size());
  use(s);
}

void write(const Writer<locd_msg_Image>& w, const std::string& robot_id, const Image& m) {
  to_wire(robot_id, m, [&](const locd_msg_Image& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const LandmarkDetections& m, const WireUse<locd_msg_LandmarkDetections>& use) {
  auto s = zeroed<locd_msg_LandmarkDetections>();
  copy_string(s.robot_id, robot_id);
  to_wire(m.header, s.header);
  std::vector<locd_msg_LandmarkDetection> items(m.detections.size());
  for (size_t i = 0; i < m.detections.size(); ++i) {
    const auto& d = m.detections[i];
    std::memset(&items[i], 0, sizeof(items[i]));
    copy_string(items[i].class_label, d.class_label);
    vec(d.position, items[i].position);
    for (int k = 0; k < 9; ++k) items[i].covariance[k] = d.covariance(k / 3, k % 3);
  }
  borrow(s.detections, items.data(), items.size());
  use(s);
}

void write(const Writer<locd_msg_LandmarkDetections>& w, const std::string& robot_id, const LandmarkDetections& m) {
  to_wire(robot_id, m, [&](const locd_msg_LandmarkDetections& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const PoseEstimate& m,
           const std::string& plugin, double update_ms, const WireUse<locd_msg_PoseEstimate>& use) {
  auto s = zeroed<locd_msg_PoseEstimate>();
  copy_string(s.robot_id, robot_id);
  to_wire(m.header, s.header);
  to_wire(m.pose, s.pose);
  for (int k = 0; k < 36; ++k) s.covariance[k] = m.covariance(k / 6, k % 6);
  vec(m.linear_velocity, s.linear_velocity);
  copy_string(s.plugin, plugin);
  s.update_ms = update_ms;
  use(s);
}

void write(const Writer<locd_msg_PoseEstimate>& w, const std::string& robot_id, const PoseEstimate& m,
           const std::string& plugin, double update_ms) {
  to_wire(robot_id, m, plugin, update_ms, [&](const locd_msg_PoseEstimate& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const PoseEstimate& m, const WireUse<locd_msg_InitialPose>& use) {
  auto s = zeroed<locd_msg_InitialPose>();
  copy_string(s.robot_id, robot_id);
  to_wire(m.header, s.header);
  to_wire(m.pose, s.pose);
  for (int k = 0; k < 36; ++k) s.covariance[k] = m.covariance(k / 6, k % 6);
  use(s);
}

void write(const Writer<locd_msg_InitialPose>& w, const std::string& robot_id, const PoseEstimate& m) {
  to_wire(robot_id, m, [&](const locd_msg_InitialPose& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const Header& h, const GridLayer& g, const WireUse<locd_msg_GridMap>& use) {
  auto s = zeroed<locd_msg_GridMap>();
  copy_string(s.robot_id, robot_id);
  copy_string(s.layer, g.layer);
  to_wire(h, s.header);
  s.resolution = g.resolution;
  s.origin_x = g.origin.x();
  s.origin_y = g.origin.y();
  s.width = static_cast<uint32_t>(g.width);
  s.height = static_cast<uint32_t>(g.height);
  borrow(s.cells, g.cells.data(), g.cells.size());
  use(s);
}

void write(const Writer<locd_msg_GridMap>& w, const std::string& robot_id, const Header& h, const GridLayer& g) {
  to_wire(robot_id, h, g, [&](const locd_msg_GridMap& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const Header& h, const PointCloud& m, const WireUse<locd_msg_PointCloudMap>& use) {
  auto s = zeroed<locd_msg_PointCloudMap>();
  copy_string(s.robot_id, robot_id);
  to_wire(h, s.header);
  borrow(s.xyz, m.points.data(), 3 * m.points.size());
  borrow(s.intensity, m.intensity.data(), m.intensity.size());
  use(s);
}

void write(const Writer<locd_msg_PointCloudMap>& w, const std::string& robot_id, const Header& h, const PointCloud& m) {
  to_wire(robot_id, h, m, [&](const locd_msg_PointCloudMap& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const Header& h,
           const std::vector<MapFeature>& features, const WireUse<locd_msg_LandmarkMap>& use) {
  auto s = zeroed<locd_msg_LandmarkMap>();
  copy_string(s.robot_id, robot_id);
  to_wire(h, s.header);
  std::vector<locd_msg_LandmarkFeature> items(features.size());
  for (size_t i = 0; i < features.size(); ++i) {
    std::memset(&items[i], 0, sizeof(items[i]));
    copy_string(items[i].id, features[i].id);
    copy_string(items[i].kind, features[i].kind);
    vec(features[i].a, items[i].a);
    vec(features[i].b, items[i].b);
  }
  borrow(s.features, items.data(), items.size());
  use(s);
}

void write(const Writer<locd_msg_LandmarkMap>& w, const std::string& robot_id, const Header& h,
           const std::vector<MapFeature>& features) {
  to_wire(robot_id, h, features, [&](const locd_msg_LandmarkMap& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const Header& h,
           const std::string& plugin, const Diagnostics& d, const WireUse<locd_msg_Diagnostics>& use) {
  auto s = zeroed<locd_msg_Diagnostics>();
  copy_string(s.robot_id, robot_id);
  to_wire(h, s.header);
  copy_string(s.plugin, plugin);
  std::vector<locd_msg_NamedValue> values(d.values.size());
  for (size_t i = 0; i < d.values.size(); ++i) {
    std::memset(&values[i], 0, sizeof(values[i]));
    copy_string(values[i].name, d.values[i].first);
    values[i].value = d.values[i].second;
  }
  std::vector<locd_msg_Particle> particles(d.particles.size());
  for (size_t i = 0; i < d.particles.size(); ++i) {
    particles[i] = {d.particles[i].x, d.particles[i].y, d.particles[i].yaw, d.particles[i].weight};
  }
  std::vector<locd_msg_Association> associations(d.associations.size());
  for (size_t i = 0; i < d.associations.size(); ++i) {
    std::memset(&associations[i], 0, sizeof(associations[i]));
    associations[i].measurement = d.associations[i].measurement;
    copy_string(associations[i].feature_id, d.associations[i].feature_id);
    associations[i].candidates = d.associations[i].candidates;
    associations[i].mahalanobis2 = d.associations[i].mahalanobis2;
  }
  borrow(s.values, values.data(), values.size());
  borrow(s.particles, particles.data(), particles.size());
  borrow(s.associations, associations.data(), associations.size());
  use(s);
}

void write(const Writer<locd_msg_Diagnostics>& w, const std::string& robot_id, const Header& h,
           const std::string& plugin, const Diagnostics& d) {
  to_wire(robot_id, h, plugin, d, [&](const locd_msg_Diagnostics& s) { w.write(s); });
}

void to_wire(const std::string& robot_id, const ExplorationGoal& g,
           const std::string& plugin, const WireUse<locd_msg_ExplorationGoal>& use) {
  auto s = zeroed<locd_msg_ExplorationGoal>();
  copy_string(s.robot_id, robot_id);
  to_wire(g.header, s.header);
  to_wire(g.pose, s.pose);
  s.score = g.score;
  s.done = g.done;
  copy_string(s.plugin, plugin);
  use(s);
}

void write(const Writer<locd_msg_ExplorationGoal>& w, const std::string& robot_id, const ExplorationGoal& g,
           const std::string& plugin) {
  to_wire(robot_id, g, plugin, [&](const locd_msg_ExplorationGoal& s) { w.write(s); });
}

}  // namespace locd::dds
