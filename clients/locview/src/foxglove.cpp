#include "foxglove.hpp"

#include <Eigen/Eigenvalues>
#include <websocketpp/base64/base64.hpp>

#include <cmath>
#include <cstring>
#include <vector>
#include <map>
#include <stdexcept>

#include "locd/client/wire.hpp"

namespace locd::view {
namespace {

// ------------------------------------------------------------------------------ JSON schemas

Json type(const char* t) { return {{"type", t}}; }
Json object(Json properties) { return {{"type", "object"}, {"properties", std::move(properties)}}; }
Json array(Json items) { return {{"type", "array"}, {"items", std::move(items)}}; }
Json bytes() { return {{"type", "string"}, {"contentEncoding", "base64"}}; }
Json time() { return object({{"sec", type("integer")}, {"nsec", type("integer")}}); }
Json vector3() { return object({{"x", type("number")}, {"y", type("number")}, {"z", type("number")}}); }
Json quaternion() {
  return object({{"x", type("number")}, {"y", type("number")}, {"z", type("number")}, {"w", type("number")}});
}
Json pose() { return object({{"position", vector3()}, {"orientation", quaternion()}}); }
Json color() { return object({{"r", type("number")}, {"g", type("number")}, {"b", type("number")}, {"a", type("number")}}); }
Json packed_fields() {
  return array(object({{"name", type("string")}, {"offset", type("integer")}, {"type", type("integer")}}));
}
Json titled(const std::string& name, Json schema) {
  schema["title"] = name;
  return schema;
}

std::map<std::string, std::string> make_schemas() {
  std::map<std::string, Json> s;
  s["foxglove.PoseInFrame"] = object({{"timestamp", time()}, {"frame_id", type("string")}, {"pose", pose()}});
  s["foxglove.PosesInFrame"] = object({{"timestamp", time()}, {"frame_id", type("string")}, {"poses", array(pose())}});
  s["foxglove.FrameTransform"] = object({{"timestamp", time()}, {"parent_frame_id", type("string")},
                                         {"child_frame_id", type("string")}, {"translation", vector3()},
                                         {"rotation", quaternion()}});
  s["foxglove.PointCloud"] = object({{"timestamp", time()}, {"frame_id", type("string")}, {"pose", pose()},
                                     {"point_stride", type("integer")}, {"fields", packed_fields()}, {"data", bytes()}});
  s["foxglove.Grid"] = object({{"timestamp", time()}, {"frame_id", type("string")}, {"pose", pose()},
                               {"column_count", type("integer")},
                               {"cell_size", object({{"x", type("number")}, {"y", type("number")}})},
                               {"row_stride", type("integer")}, {"cell_stride", type("integer")},
                               {"fields", packed_fields()}, {"data", bytes()}});
  const Json sphere = object({{"pose", pose()}, {"size", vector3()}, {"color", color()}});
  const Json line = object({{"type", type("integer")}, {"pose", pose()}, {"thickness", type("number")},
                            {"scale_invariant", type("boolean")}, {"points", array(vector3())}, {"color", color()},
                            {"colors", array(color())}, {"indices", array(type("integer"))}});
  const Json text = object({{"pose", pose()}, {"billboard", type("boolean")}, {"font_size", type("number")},
                            {"scale_invariant", type("boolean")}, {"color", color()}, {"text", type("string")}});
  const Json entity = object({{"timestamp", time()}, {"frame_id", type("string")}, {"id", type("string")},
                              {"lifetime", time()}, {"frame_locked", type("boolean")},
                              {"metadata", array(object({{"key", type("string")}, {"value", type("string")}}))},
                              {"arrows", array(type("object"))}, {"cubes", array(type("object"))},
                              {"spheres", array(sphere)}, {"cylinders", array(type("object"))},
                              {"lines", array(line)}, {"triangles", array(type("object"))},
                              {"texts", array(text)}, {"models", array(type("object"))}});
  s["foxglove.SceneUpdate"] = object(
      {{"deletions", array(object({{"timestamp", time()}, {"type", type("integer")}, {"id", type("string")}}))},
       {"entities", array(entity)}});
  s["locd.SessionStatus"] = object({{"robot_id", type("string")}, {"server_id", type("string")},
                                    {"state", type("string")}, {"plugin", type("string")},
                                    {"request_id", type("integer")}, {"request_ok", type("boolean")},
                                    {"message", type("string")}, {"last_error", type("string")},
                                    {"received", type("integer")}, {"used", type("integer")},
                                    {"dropped", type("integer")}, {"rejected", type("integer")},
                                    {"updates", type("integer")}, {"last_update_ms", type("number")},
                                    {"failures", type("integer")}, {"localization", type("string")},
                                    {"localization_reason", type("string")}, {"throttled", type("integer")}});
  s["locd.DiagnosticValues"] = object({{"timestamp", time()}, {"plugin", type("string")},
                                       {"values", {{"type", "object"}, {"additionalProperties", type("number")}}},
                                       {"particles", type("integer")}, {"associations", type("integer")}});
  std::map<std::string, std::string> text_schemas;
  for (auto& [name, schema] : s) text_schemas[name] = titled(name, schema).dump();
  return text_schemas;
}

// ------------------------------------------------------------------------------ messages

Json stamp(int64_t ns) {
  const int64_t sec = ns >= 0 ? ns / 1'000'000'000 : -((-ns + 999'999'999) / 1'000'000'000);
  return {{"sec", sec}, {"nsec", ns - sec * 1'000'000'000}};
}
Json vec(const locd_msg_Vector3& v) { return {{"x", v.x}, {"y", v.y}, {"z", v.z}}; }
Json quat(const locd_msg_Quaternion& q) { return {{"x", q.x}, {"y", q.y}, {"z", q.z}, {"w", q.w}}; }
Json pose_json(const locd_msg_Pose3D& p) { return {{"position", vec(p.position)}, {"orientation", quat(p.orientation)}}; }
Json identity_pose() { return {{"position", {{"x", 0}, {"y", 0}, {"z", 0}}}, {"orientation", {{"x", 0}, {"y", 0}, {"z", 0}, {"w", 1}}}}; }
Json rgba(double r, double g, double b, double a) { return {{"r", r}, {"g", g}, {"b", b}, {"a", a}}; }
Json yaw_pose(double x, double y, double z, double yaw) {
  return {{"position", {{"x", x}, {"y", y}, {"z", z}}},
          {"orientation", {{"x", 0.0}, {"y", 0.0}, {"z", std::sin(yaw / 2)}, {"w", std::cos(yaw / 2)}}}};
}

std::string text(const char* s, size_t n) {
  size_t len = 0;
  while (len < n && s[len] != '\0') ++len;
  return std::string(s, len);
}
template <size_t N>
std::string text(const char (&s)[N]) { return text(s, N); }

constexpr int kFloat32 = 7;  // foxglove.NumericType

// A SceneEntity lists every kind of primitive, empty where it has none.
void no_other_primitives(Json& entity) {
  for (const char* kind : {"arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models"}) {
    if (!entity.contains(kind)) entity[kind] = Json::array();
  }
}

Json xyz_cloud(const char* frame, const Json& origin, const float* xyz, size_t points, const float* intensity,
               size_t intensities, const locd_msg_MessageHeader& header) {
  const bool with_intensity = intensities == points && points > 0;
  const size_t stride = with_intensity ? 16 : 12;
  std::string data(points * stride, '\0');
  for (size_t i = 0; i < points; ++i) {
    std::memcpy(&data[i * stride], xyz + 3 * i, 12);
    if (with_intensity) std::memcpy(&data[i * stride + 12], intensity + i, 4);
  }
  Json fields = Json::array({{{"name", "x"}, {"offset", 0}, {"type", kFloat32}},
                             {{"name", "y"}, {"offset", 4}, {"type", kFloat32}},
                             {{"name", "z"}, {"offset", 8}, {"type", kFloat32}}});
  if (with_intensity) fields.push_back({{"name", "intensity"}, {"offset", 12}, {"type", kFloat32}});
  return {{"timestamp", stamp(header.stamp_ns)}, {"frame_id", frame}, {"pose", origin},
          {"point_stride", stride}, {"fields", fields}, {"data", base64(data.data(), data.size())}};
}

}  // namespace

const std::string& json_schema(const std::string& schema_name) {
  static const std::map<std::string, std::string> schemas = make_schemas();
  return schemas.at(schema_name);
}

std::string base_frame(const std::string& robot_id) { return robot_id + "/base_link"; }

std::string base64(const void* data, size_t size) {
  return websocketpp::base64_encode(static_cast<const unsigned char*>(data), size);
}

Json pose_in_frame(const locd_msg_MessageHeader& header, const locd_msg_Pose3D& pose, const char* frame) {
  return {{"timestamp", stamp(header.stamp_ns)}, {"frame_id", frame}, {"pose", pose_json(pose)}};
}

Json base_transform(const locd_msg_PoseEstimate& pose) {
  return {{"timestamp", stamp(pose.header.stamp_ns)}, {"parent_frame_id", "map"},
          {"child_frame_id", base_frame(text(pose.robot_id))}, {"translation", vec(pose.pose.position)},
          {"rotation", quat(pose.pose.orientation)}};
}

Json covariance_ellipse(const locd_msg_PoseEstimate& pose) {
  Eigen::Matrix2d c;
  c << pose.covariance[0], pose.covariance[1], pose.covariance[6], pose.covariance[7];
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(0.5 * (c + c.transpose()));
  const Eigen::Vector2d sigma = eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  const Eigen::Vector2d major = eigen.eigenvectors().col(1);
  const double angle = std::atan2(major.y(), major.x());
  const std::string robot = text(pose.robot_id);
  // Sphere size is a diameter: 2 sigma half axes = 4 sigma across.
  const Json sphere = {{"pose", yaw_pose(pose.pose.position.x, pose.pose.position.y, pose.pose.position.z, angle)},
                       {"size", {{"x", 4 * sigma(1)}, {"y", 4 * sigma(0)}, {"z", 0.01}}},
                       {"color", rgba(0.2, 0.6, 1.0, 0.35)}};
  Json entity = {{"timestamp", stamp(pose.header.stamp_ns)}, {"frame_id", "map"}, {"id", robot + "/covariance"},
                       {"lifetime", {{"sec", 0}, {"nsec", 0}}}, {"frame_locked", false},
                       {"metadata", Json::array({{{"key", "robot_id"}, {"value", robot}}})},
                       {"spheres", Json::array({sphere})}};
  no_other_primitives(entity);
  return {{"deletions", Json::array()}, {"entities", Json::array({entity})}};
}

Json particles(const locd_msg_Diagnostics& d) {
  Json poses = Json::array();
  for (uint32_t i = 0; i < d.particles._length; ++i) {
    const locd_msg_Particle& p = d.particles._buffer[i];
    poses.push_back(yaw_pose(p.x, p.y, 0.0, p.yaw));
  }
  return {{"timestamp", stamp(d.header.stamp_ns)}, {"frame_id", "map"}, {"poses", poses}};
}

Json diagnostic_values(const locd_msg_Diagnostics& d) {
  Json values = Json::object();
  for (uint32_t i = 0; i < d.values._length; ++i) values[text(d.values._buffer[i].name)] = d.values._buffer[i].value;
  return {{"timestamp", stamp(d.header.stamp_ns)}, {"plugin", text(d.plugin)}, {"values", values},
          {"particles", d.particles._length}, {"associations", d.associations._length}};
}

Json laser_scan(const locd_msg_LaserScan& scan) {
  // The returns as points in the laser's plane (beams without a return, out of [range_min,
  // range_max], are left out), placed by the laser's pose in base_link.
  std::vector<float> xyz, intensity;
  const bool with_intensity = scan.intensities._length == scan.ranges._length;
  for (uint32_t i = 0; i < scan.ranges._length; ++i) {
    const float r = scan.ranges._buffer[i];
    if (!(r >= scan.range_min && r <= scan.range_max)) continue;
    const double a = scan.angle_min + scan.angle_increment * static_cast<double>(i);
    xyz.insert(xyz.end(), {static_cast<float>(r * std::cos(a)), static_cast<float>(r * std::sin(a)), 0.0f});
    if (with_intensity) intensity.push_back(scan.intensities._buffer[i]);
  }
  return xyz_cloud(base_frame(text(scan.robot_id)).c_str(), pose_json(scan.sensor_pose), xyz.data(), xyz.size() / 3,
                   intensity.data(), intensity.size(), scan.header);
}

Json sensor_cloud(const locd_msg_PointCloud& cloud) {
  return xyz_cloud(base_frame(text(cloud.robot_id)).c_str(), pose_json(cloud.sensor_pose), cloud.xyz._buffer,
                   cloud.xyz._length / 3, cloud.intensity._buffer, cloud.intensity._length, cloud.header);
}

Json map_cloud(const locd_msg_PointCloudMap& cloud) {
  return xyz_cloud("map", identity_pose(), cloud.xyz._buffer, cloud.xyz._length / 3, cloud.intensity._buffer,
                   cloud.intensity._length, cloud.header);
}

Json grid(const locd_msg_GridMap& g) {
  const size_t cells = std::min<size_t>(g.cells._length, size_t(g.width) * g.height);
  return {{"timestamp", stamp(g.header.stamp_ns)}, {"frame_id", "map"},
          {"pose", yaw_pose(g.origin_x, g.origin_y, 0.0, 0.0)}, {"column_count", g.width},
          {"cell_size", {{"x", g.resolution}, {"y", g.resolution}}}, {"row_stride", 4 * g.width}, {"cell_stride", 4},
          {"fields", Json::array({{{"name", text(g.layer)}, {"offset", 0}, {"type", kFloat32}}})},
          {"data", base64(g.cells._buffer, cells * 4)}};
}

Json landmark_scene(const locd_msg_LandmarkMap& map) {
  Json line_points = Json::array(), spheres = Json::array(), texts = Json::array();
  for (uint32_t i = 0; i < map.features._length; ++i) {
    const locd_msg_LandmarkFeature& f = map.features._buffer[i];
    if (text(f.kind) == "line") {
      line_points.push_back(vec(f.a));
      line_points.push_back(vec(f.b));
    } else {
      spheres.push_back({{"pose", yaw_pose(f.a.x, f.a.y, f.a.z, 0.0)}, {"size", {{"x", 0.15}, {"y", 0.15}, {"z", 0.15}}},
                         {"color", rgba(1.0, 0.6, 0.1, 0.9)}});
      texts.push_back({{"pose", yaw_pose(f.a.x, f.a.y, f.a.z + 0.2, 0.0)}, {"billboard", true}, {"font_size", 12},
                       {"scale_invariant", true}, {"color", rgba(1, 1, 1, 1)}, {"text", text(f.kind) + " " + text(f.id)}});
    }
  }
  Json lines = Json::array();
  if (!line_points.empty()) {
    lines.push_back({{"type", 2}, {"pose", identity_pose()}, {"thickness", 0.05}, {"scale_invariant", false},
                     {"points", line_points}, {"color", rgba(0.1, 1.0, 0.3, 1.0)}, {"colors", Json::array()},
                     {"indices", Json::array()}});  // 2 = LINE_LIST
  }
  const std::string robot = text(map.robot_id);
  Json entity = {{"timestamp", stamp(map.header.stamp_ns)}, {"frame_id", "map"}, {"id", robot + "/landmark_map"},
                       {"lifetime", {{"sec", 0}, {"nsec", 0}}}, {"frame_locked", false},
                       {"metadata", Json::array({{{"key", "robot_id"}, {"value", robot}}})},
                       {"spheres", spheres}, {"lines", lines}, {"texts", texts}};
  no_other_primitives(entity);
  return {{"deletions", Json::array()}, {"entities", Json::array({entity})}};
}

Json exploration_goal(const locd_msg_ExplorationGoal& goal) { return pose_in_frame(goal.header, goal.pose); }

Json session_status(const locd_msg_SessionStatus& m) {
  const SessionStatus s = status_from_wire(m);
  return {{"robot_id", s.robot_id}, {"server_id", s.server_id}, {"state", s.state}, {"plugin", s.plugin},
          {"request_id", s.request_id}, {"request_ok", s.request_ok}, {"message", s.message},
          {"last_error", s.last_error}, {"received", s.received}, {"used", s.used}, {"dropped", s.dropped},
          {"rejected", s.rejected}, {"updates", s.updates}, {"last_update_ms", s.last_update_ms},
          {"failures", s.failures}, {"localization", s.localization},
          {"localization_reason", s.localization_reason}, {"throttled", s.throttled}};
}

}  // namespace locd::view
