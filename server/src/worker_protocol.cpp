#include "locd/server/worker_protocol.hpp"

#include <cstring>
#include <type_traits>

namespace locd::server::worker {
namespace {

// Bounds of what a frame may carry besides the configured limits (the IDL's own bounds, or
// generous ones for text that never travels on DDS).
constexpr size_t kMaxShortText = 4096;           // names, ids, frame ids, messages
constexpr size_t kMaxLogText = 16384;
constexpr size_t kMaxConfigText = 4 * 1024 * 1024;  // a boot config file or a request's YAML
constexpr size_t kMaxPathKeys = 16;
constexpr size_t kMaxMapDirectories = 256;
constexpr size_t kMaxNamedValues = 256;           // IDL Diagnostics.values
constexpr size_t kMaxAssociations = 4096;         // IDL Diagnostics.associations
constexpr size_t kMaxMapFeatures = 1048576;       // IDL LandmarkMap.features
constexpr size_t kMaxImageChannels = 3;

class Writer {
 public:
  explicit Writer(std::string& out) : out_(out) {}
  template <typename T>
  void pod(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  void text(const std::string& s) {
    pod<uint64_t>(s.size());
    out_.append(s);
  }
  void count(size_t n) { pod<uint64_t>(n); }
  // Plain elements (numbers, Particle2D, Eigen::Vector3f: contiguous scalars, no padding).
  template <typename T>
  void array(const T* data, size_t n) {
    count(n);
    out_.append(reinterpret_cast<const char*>(data), n * sizeof(T));
  }
  void isometry(const Eigen::Isometry3d& T) {
    const Eigen::Matrix<double, 3, 4> m = T.matrix().topRows<3>();
    out_.append(reinterpret_cast<const char*>(m.data()), sizeof(double) * 12);
  }
  template <typename Derived>
  void matrix(const Eigen::MatrixBase<Derived>& m) {
    const typename Derived::PlainObject plain = m;
    out_.append(reinterpret_cast<const char*>(plain.data()), sizeof(typename Derived::Scalar) * plain.size());
  }
  void header(const Header& h) {
    pod(h.stamp_ns);
    text(h.frame_id);
  }

 private:
  std::string& out_;
};

class Reader {
 public:
  explicit Reader(std::string_view bytes) : data_(bytes.data()), left_(bytes.size()) {}
  template <typename T>
  T pod() {
    static_assert(std::is_trivially_copyable_v<T>);
    need(sizeof(T), "a field");
    T value;
    std::memcpy(&value, data_, sizeof(T));
    skip(sizeof(T));
    return value;
  }
  std::string text(size_t max, const char* what) {
    const size_t n = count(max, 1, what);
    std::string s(data_, n);
    skip(n);
    return s;
  }
  // A count of `element_bytes`-sized items: at most `max`, and no more than the bytes left.
  size_t count(size_t max, size_t element_bytes, const char* what) {
    const uint64_t n = pod<uint64_t>();
    if (n > max) throw ProtocolError(std::string(what) + ": " + std::to_string(n) + " exceed the bound " + std::to_string(max));
    if (element_bytes > 0 && n > left_ / element_bytes) {
      throw ProtocolError(std::string(what) + ": " + std::to_string(n) + " announced, the frame holds fewer");
    }
    return static_cast<size_t>(n);
  }
  template <typename T>
  std::vector<T> array(size_t max, const char* what) {
    const size_t n = count(max, sizeof(T), what);
    std::vector<T> v(n);
    if (n > 0) std::memcpy(static_cast<void*>(v.data()), data_, n * sizeof(T));  // T: plain values (floats, Eigen vectors)
    skip(n * sizeof(T));
    return v;
  }
  Eigen::Isometry3d isometry() {
    Eigen::Matrix<double, 3, 4> m;
    need(sizeof(double) * 12, "a pose");
    std::memcpy(m.data(), data_, sizeof(double) * 12);
    skip(sizeof(double) * 12);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.matrix().topRows<3>() = m;
    return T;
  }
  template <typename M>
  M matrix() {
    M m;
    const size_t bytes = sizeof(typename M::Scalar) * static_cast<size_t>(m.size());
    need(bytes, "a matrix");
    std::memcpy(m.data(), data_, bytes);
    skip(bytes);
    return m;
  }
  Header header() {
    Header h;
    h.stamp_ns = pod<int64_t>();
    h.frame_id = text(kMaxShortText, "frame id");
    return h;
  }
  bool flag() { return pod<uint8_t>() != 0; }
  void finish(const char* what) const {
    if (left_ != 0) throw ProtocolError(std::string(what) + ": " + std::to_string(left_) + " bytes left over");
  }

 private:
  void need(size_t bytes, const char* what) const {
    if (bytes > left_) throw ProtocolError(std::string("frame ends inside ") + what);
  }
  void skip(size_t bytes) {
    data_ += bytes;
    left_ -= bytes;
  }
  const char* data_;
  size_t left_;
};

// Writes the header with a placeholder length, runs `body`, then fills the length in.
template <typename Body>
void frame(std::string& out, Op op, uint64_t instance, Body&& body) {
  const size_t start = out.size();
  FrameHeader h;
  h.op = static_cast<uint32_t>(op);
  h.instance = instance;
  out.append(reinterpret_cast<const char*>(&h), sizeof h);
  Writer w(out);
  body(w);
  h.length = out.size() - start - sizeof h;
  std::memcpy(&out[start], &h, sizeof h);
}

bool known_op(uint32_t op) {
  switch (static_cast<Op>(op)) {
    case Op::kConfigure:
    case Op::kSetPose:
    case Op::kUpdate:
    case Op::kSaveMap:
    case Op::kRelease:
    case Op::kReply:
    case Op::kLog: return true;
  }
  return false;
}

void write_pose_estimate(Writer& w, const PoseEstimate& e) {
  w.header(e.header);
  w.isometry(e.pose);
  w.matrix(e.covariance);
  w.matrix(e.linear_velocity);
}

PoseEstimate read_pose_estimate(Reader& r) {
  PoseEstimate e;
  e.header = r.header();
  e.pose = r.isometry();
  e.covariance = r.matrix<Matrix6d>();
  e.linear_velocity = r.matrix<Eigen::Vector3d>();
  return e;
}

static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float));
static_assert(sizeof(Particle2D) == 4 * sizeof(double));

void write_cloud(Writer& w, const PointCloud& c) {
  w.header(c.header);
  w.isometry(c.sensor_pose);
  w.array(c.points.data(), c.points.size());
  w.array(c.intensity.data(), c.intensity.size());
}

PointCloud read_cloud(Reader& r, size_t max_points) {
  PointCloud c;
  c.header = r.header();
  c.sensor_pose = r.isometry();
  c.points = r.array<Eigen::Vector3f>(max_points, "points");
  c.intensity = r.array<float>(max_points, "intensities");
  return c;
}

enum class Kind : uint8_t { kOdometry, kImu, kScan, kCloud, kImage, kDetections };

void write_measurement(Writer& w, const Measurement& m) {
  w.pod(static_cast<uint8_t>(m.index()));
  std::visit(
      [&](const auto& v) {
        using T = std::decay_t<decltype(v)>;
        w.header(v.header);
        if constexpr (std::is_same_v<T, Odometry>) {
          w.isometry(v.pose);
          w.matrix(v.linear_velocity);
          w.matrix(v.angular_velocity);
        } else if constexpr (std::is_same_v<T, Imu>) {
          w.matrix(v.orientation.coeffs());
          w.matrix(v.angular_velocity);
          w.matrix(v.linear_acceleration);
          w.pod(v.orientation_stddev);
          w.pod(v.acceleration_stddev);
        } else if constexpr (std::is_same_v<T, LaserScan>) {
          w.isometry(v.sensor_pose);
          w.pod(v.angle_min);
          w.pod(v.angle_increment);
          w.pod(v.range_min);
          w.pod(v.range_max);
          w.array(v.ranges.data(), v.ranges.size());
          w.array(v.intensities.data(), v.intensities.size());
        } else if constexpr (std::is_same_v<T, PointCloud>) {
          w.isometry(v.sensor_pose);
          w.array(v.points.data(), v.points.size());
          w.array(v.intensity.data(), v.intensity.size());
        } else if constexpr (std::is_same_v<T, Image>) {
          w.pod(static_cast<int32_t>(v.width));
          w.pod(static_cast<int32_t>(v.height));
          w.pod(static_cast<int32_t>(v.channels));
          w.array(v.data.data(), v.data.size());
        } else {
          w.count(v.detections.size());
          for (const auto& d : v.detections) {
            w.text(d.class_label);
            w.matrix(d.position);
            w.matrix(d.covariance);
          }
        }
      },
      m);
}

Measurement read_measurement(Reader& r, const Limits& limits) {
  const uint8_t kind = r.pod<uint8_t>();
  const Header header = r.header();
  switch (static_cast<Kind>(kind)) {
    case Kind::kOdometry: {
      Odometry o;
      o.header = header;
      o.pose = r.isometry();
      o.linear_velocity = r.matrix<Eigen::Vector3d>();
      o.angular_velocity = r.matrix<Eigen::Vector3d>();
      return o;
    }
    case Kind::kImu: {
      Imu i;
      i.header = header;
      i.orientation.coeffs() = r.matrix<Eigen::Vector4d>();
      i.angular_velocity = r.matrix<Eigen::Vector3d>();
      i.linear_acceleration = r.matrix<Eigen::Vector3d>();
      i.orientation_stddev = r.pod<double>();
      i.acceleration_stddev = r.pod<double>();
      return i;
    }
    case Kind::kScan: {
      LaserScan s;
      s.header = header;
      s.sensor_pose = r.isometry();
      s.angle_min = r.pod<float>();
      s.angle_increment = r.pod<float>();
      s.range_min = r.pod<float>();
      s.range_max = r.pod<float>();
      s.ranges = r.array<float>(limits.max_scan_beams, "scan ranges");
      s.intensities = r.array<float>(limits.max_scan_beams, "scan intensities");
      return s;
    }
    case Kind::kCloud: {
      PointCloud c;
      c.header = header;
      c.sensor_pose = r.isometry();
      c.points = r.array<Eigen::Vector3f>(limits.max_cloud_points, "cloud points");
      c.intensity = r.array<float>(limits.max_cloud_points, "cloud intensities");
      return c;
    }
    case Kind::kImage: {
      Image i;
      i.header = header;
      i.width = r.pod<int32_t>();
      i.height = r.pod<int32_t>();
      i.channels = r.pod<int32_t>();
      i.data = r.array<uint8_t>(limits.max_image_pixels * kMaxImageChannels, "image bytes");
      return i;
    }
    case Kind::kDetections: {
      LandmarkDetections d;
      d.header = header;
      const size_t n = r.count(limits.max_detections, 1, "detections");
      d.detections.resize(n);
      for (auto& detection : d.detections) {
        detection.class_label = r.text(kMaxShortText, "class label");
        detection.position = r.matrix<Eigen::Vector3d>();
        detection.covariance = r.matrix<Eigen::Matrix3d>();
      }
      return d;
    }
  }
  throw ProtocolError("unknown measurement kind " + std::to_string(kind));
}

size_t max_map_points(const Limits& limits) { return std::max(limits.max_cloud_points, limits.max_map_cells); }

void write_result(Writer& w, const UpdateResult& u) {
  w.pod<uint8_t>(u.estimate.has_value());
  if (u.estimate) write_pose_estimate(w, *u.estimate);
  w.count(u.diagnostics.values.size());
  for (const auto& [name, value] : u.diagnostics.values) {
    w.text(name);
    w.pod(value);
  }
  w.array(u.diagnostics.particles.data(), u.diagnostics.particles.size());
  w.count(u.diagnostics.associations.size());
  for (const auto& a : u.diagnostics.associations) {
    w.pod(a.measurement);
    w.text(a.feature_id);
    w.pod(a.candidates);
    w.pod(a.mahalanobis2);
  }
  w.pod<uint8_t>(u.grid.has_value());
  if (u.grid) {
    w.text(u.grid->layer);
    w.pod(u.grid->resolution);
    w.matrix(u.grid->origin);
    w.pod(static_cast<int32_t>(u.grid->width));
    w.pod(static_cast<int32_t>(u.grid->height));
    w.array(u.grid->cells.data(), u.grid->cells.size());
  }
  w.pod<uint8_t>(u.map_cloud.has_value());
  if (u.map_cloud) write_cloud(w, *u.map_cloud);
  w.pod<uint8_t>(u.landmark_map.has_value());
  if (u.landmark_map) {
    w.count(u.landmark_map->size());
    for (const auto& f : *u.landmark_map) {
      w.text(f.id);
      w.text(f.kind);
      w.matrix(f.a);
      w.matrix(f.b);
    }
  }
  w.pod<uint8_t>(u.exploration_goal.has_value());
  if (u.exploration_goal) {
    w.header(u.exploration_goal->header);
    w.isometry(u.exploration_goal->pose);
    w.pod(u.exploration_goal->score);
    w.pod<uint8_t>(u.exploration_goal->done);
  }
  w.pod<uint8_t>(u.localization.has_value());
  if (u.localization) {
    w.pod(static_cast<uint8_t>(u.localization->state));
    w.text(u.localization->reason);
  }
}

UpdateResult read_result(Reader& r, const Limits& limits) {
  UpdateResult u;
  if (r.flag()) u.estimate = read_pose_estimate(r);
  const size_t values = r.count(kMaxNamedValues, 1, "diagnostic values");
  u.diagnostics.values.reserve(values);
  for (size_t i = 0; i < values; ++i) {
    std::string name = r.text(kMaxShortText, "value name");
    u.diagnostics.values.emplace_back(std::move(name), r.pod<double>());
  }
  u.diagnostics.particles = r.array<Particle2D>(limits.max_particles, "particles");
  const size_t associations = r.count(kMaxAssociations, 1, "associations");
  u.diagnostics.associations.resize(associations);
  for (auto& a : u.diagnostics.associations) {
    a.measurement = r.pod<uint32_t>();
    a.feature_id = r.text(kMaxShortText, "feature id");
    a.candidates = r.pod<uint32_t>();
    a.mahalanobis2 = r.pod<double>();
  }
  if (r.flag()) {
    GridLayer g;
    g.layer = r.text(kMaxShortText, "grid layer");
    g.resolution = r.pod<double>();
    g.origin = r.matrix<Eigen::Vector2d>();
    g.width = r.pod<int32_t>();
    g.height = r.pod<int32_t>();
    g.cells = r.array<float>(limits.max_map_cells, "grid cells");
    u.grid = std::move(g);
  }
  if (r.flag()) u.map_cloud = read_cloud(r, max_map_points(limits));
  if (r.flag()) {
    const size_t n = r.count(kMaxMapFeatures, 1, "map features");
    std::vector<MapFeature> features(n);
    for (auto& f : features) {
      f.id = r.text(kMaxShortText, "feature id");
      f.kind = r.text(kMaxShortText, "feature kind");
      f.a = r.matrix<Eigen::Vector3d>();
      f.b = r.matrix<Eigen::Vector3d>();
    }
    u.landmark_map = std::move(features);
  }
  if (r.flag()) {
    ExplorationGoal g;
    g.header = r.header();
    g.pose = r.isometry();
    g.score = r.pod<double>();
    g.done = r.flag();
    u.exploration_goal = g;
  }
  if (r.flag()) {
    const uint8_t state = r.pod<uint8_t>();
    if (state > static_cast<uint8_t>(LocalizationState::kLost)) {
      throw ProtocolError("unknown localization state " + std::to_string(state));
    }
    LocalizationAssessment a;
    a.state = static_cast<LocalizationState>(state);
    a.reason = r.text(kMaxShortText, "localization reason");
    u.localization = std::move(a);
  }
  return u;
}

}  // namespace

const char* op_name(Op op) {
  switch (op) {
    case Op::kConfigure: return "configure";
    case Op::kSetPose: return "set_pose";
    case Op::kUpdate: return "update";
    case Op::kSaveMap: return "save_map";
    case Op::kRelease: return "release";
    case Op::kReply: return "reply";
    case Op::kLog: return "log";
  }
  return "unknown";
}

uint64_t max_payload_bytes(const Limits& limits) {
  // Generous: every kind of payload at its limit at once, plus room for text.
  constexpr uint64_t kFixedPart = 64ull << 20;
  return kFixedPart + 16ull * limits.max_cloud_points + 20ull * max_map_points(limits) +
         4ull * limits.max_map_cells + sizeof(Particle2D) * limits.max_particles +
         kMaxImageChannels * limits.max_image_pixels + 8ull * limits.max_scan_beams +
         256ull * limits.max_detections + kMaxMapFeatures * 192ull;
}

void append_configure(std::string& out, uint64_t instance, const ConfigureRequest& c) {
  frame(out, Op::kConfigure, instance, [&](Writer& w) {
    w.text(c.robot_id);
    w.pod(c.limits);
    w.count(c.map_directories.size());
    for (const auto& d : c.map_directories) w.text(d);
    w.text(c.output_directory);
    w.text(c.config.yaml);
    w.text(c.config.source);
    w.count(c.config.path.size());
    for (const auto& key : c.config.path) w.text(key);
  });
}

void append_set_pose(std::string& out, uint64_t instance, const PoseEstimate& pose) {
  frame(out, Op::kSetPose, instance, [&](Writer& w) { write_pose_estimate(w, pose); });
}

void append_update(std::string& out, uint64_t instance, const Measurement& measurement) {
  frame(out, Op::kUpdate, instance, [&](Writer& w) { write_measurement(w, measurement); });
}

void append_request(std::string& out, uint64_t instance, Op op) {
  frame(out, op, instance, [](Writer&) {});
}

void append_reply(std::string& out, uint64_t instance, const Reply& reply) {
  frame(out, Op::kReply, instance, [&](Writer& w) {
    w.pod(static_cast<uint32_t>(reply.request));
    w.pod(static_cast<uint8_t>(reply.outcome));
    w.text(reply.message);
    w.pod(reply.compute_ms);
    write_result(w, reply.result);
  });
}

void append_log(std::string& out, uint64_t instance, const LogLine& line) {
  frame(out, Op::kLog, instance, [&](Writer& w) {
    w.pod(static_cast<uint8_t>(line.level));
    w.text(line.text.size() > kMaxLogText ? line.text.substr(0, kMaxLogText) : line.text);
  });
}

FrameHeader parse_header(const char* bytes, uint64_t max_payload) {
  FrameHeader h;
  std::memcpy(&h, bytes, sizeof h);
  if (h.magic != kFrameMagic) throw ProtocolError("frame without the protocol's magic number");
  if (!known_op(h.op)) throw ProtocolError("frame with unknown op " + std::to_string(h.op));
  if (h.length > max_payload) {
    throw ProtocolError("frame of " + std::to_string(h.length) + " bytes exceeds the bound of " +
                        std::to_string(max_payload) + " bytes");
  }
  return h;
}

ConfigureRequest decode_configure(std::string_view payload, const Limits&) {
  Reader r(payload);
  ConfigureRequest c;
  c.robot_id = r.text(kMaxShortText, "robot id");
  c.limits = r.pod<Limits>();
  const size_t dirs = r.count(kMaxMapDirectories, 1, "map directories");
  for (size_t i = 0; i < dirs; ++i) c.map_directories.push_back(r.text(kMaxShortText, "map directory"));
  c.output_directory = r.text(kMaxShortText, "output directory");
  c.config.yaml = r.text(kMaxConfigText, "config");
  c.config.source = r.text(kMaxShortText, "config source");
  const size_t keys = r.count(kMaxPathKeys, 1, "config path");
  for (size_t i = 0; i < keys; ++i) c.config.path.push_back(r.text(kMaxShortText, "config path key"));
  r.finish("configure");
  return c;
}

PoseEstimate decode_set_pose(std::string_view payload) {
  Reader r(payload);
  PoseEstimate e = read_pose_estimate(r);
  r.finish("set_pose");
  return e;
}

Measurement decode_update(std::string_view payload, const Limits& limits) {
  Reader r(payload);
  Measurement m = read_measurement(r, limits);
  r.finish("update");
  return m;
}

Reply decode_reply(std::string_view payload, const Limits& limits) {
  Reader r(payload);
  Reply reply;
  const uint32_t op = r.pod<uint32_t>();
  if (op < static_cast<uint32_t>(Op::kConfigure) || op > static_cast<uint32_t>(Op::kRelease)) {
    throw ProtocolError("reply to unknown request op " + std::to_string(op));
  }
  reply.request = static_cast<Op>(op);
  const uint8_t outcome = r.pod<uint8_t>();
  if (outcome > static_cast<uint8_t>(Outcome::kPluginError)) {
    throw ProtocolError("reply with unknown outcome " + std::to_string(outcome));
  }
  reply.outcome = static_cast<Outcome>(outcome);
  reply.message = r.text(kMaxLogText, "reply message");
  reply.compute_ms = r.pod<double>();
  reply.result = read_result(r, limits);
  r.finish("reply");
  return reply;
}

LogLine decode_log(std::string_view payload) {
  Reader r(payload);
  LogLine line;
  const uint8_t level = r.pod<uint8_t>();
  if (level > static_cast<uint8_t>(LogLevel::kError)) throw ProtocolError("log line with unknown level");
  line.level = static_cast<LogLevel>(level);
  line.text = r.text(kMaxLogText, "log text");
  r.finish("log");
  return line;
}

}  // namespace locd::server::worker
