// Plain measurement and estimate types a plugin sees. No DDS in here: the server's bridge
// converts IDL structs to these and back, so plugins are tested without a network.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace locd {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

// A pose's covariance is over (x, y, z, roll, pitch, yaw); a planar one over (x, y, yaw). The
// planar block of the first, and the first holding only the second (other entries zero).
inline constexpr int kPlanarIndex[3] = {0, 1, 5};
inline Eigen::Matrix3d planar_covariance(const Matrix6d& covariance) {
  Eigen::Matrix3d planar;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) planar(i, j) = covariance(kPlanarIndex[i], kPlanarIndex[j]);
  return planar;
}
inline Matrix6d pose_covariance(const Eigen::Matrix3d& planar) {
  Matrix6d covariance = Matrix6d::Zero();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) covariance(kPlanarIndex[i], kPlanarIndex[j]) = planar(i, j);
  return covariance;
}

struct Header {
  int64_t stamp_ns = 0;
  std::string frame_id;
  uint64_t sequence = 0;  // sensors: 1, 2, 3, ... per writer and topic; 0 = not numbered
};

// base_link in the odom frame, body-frame velocities.
struct Odometry {
  Header header;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
};

// Attitude of base_link in a local level frame (ENU); acceleration in body, gravity removed.
struct Imu {
  Header header;
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();
  double orientation_stddev = -1.0;   // rad, <= 0 unknown
  double acceleration_stddev = -1.0;  // m/s^2, <= 0 unknown
};

// What one range reading says, as REP 117 defines it (ROS drivers send all four).
enum class RangeReading {
  kHit,        // range_min <= r < range_max: an obstacle at r
  kNoReturn,   // +inf, or r >= range_max (a max-range reading): nothing within range_max
  kTooClose,   // -inf: an obstacle closer than range_min
  kInvalid,    // NaN, or r < range_min (0 included): an erroneous reading that says nothing
};

// A 2D scan. Beam i has angle angle_min + i * angle_increment in the sensor frame; reading(i)
// says what its range means (REP 117). Only hits are returns; the other three never count as
// disagreement with a map.
struct LaserScan {
  Header header;
  Eigen::Isometry3d sensor_pose = Eigen::Isometry3d::Identity();  // sensor in base_link
  float angle_min = 0.0f;
  float angle_increment = 0.0f;
  float range_min = 0.0f;
  float range_max = 0.0f;
  std::vector<float> ranges;
  std::vector<float> intensities;  // empty or ranges.size()

  RangeReading reading(size_t i) const;
  bool valid_return(size_t i) const { return reading(i) == RangeReading::kHit; }
  double angle(size_t i) const { return angle_min + static_cast<double>(i) * angle_increment; }
};

struct PointCloud {
  Header header;
  Eigen::Isometry3d sensor_pose = Eigen::Isometry3d::Identity();  // sensor in base_link
  std::vector<Eigen::Vector3f> points;                             // sensor frame
  std::vector<float> intensity;                                     // empty or points.size()
};

// 8-bit image, rows contiguous (step = width * channels).
struct Image {
  Header header;
  int width = 0;
  int height = 0;
  int channels = 1;  // 1 = mono8, 3 = bgr8
  std::vector<uint8_t> data;
};

struct LandmarkDetection {
  std::string class_label;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();   // base_link frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
};

struct LandmarkDetections {
  Header header;
  std::vector<LandmarkDetection> detections;
};

using Measurement = std::variant<Odometry, Imu, LaserScan, PointCloud, Image, LandmarkDetections>;

// The kinds a plugin may consume, as bits of PluginDescriptor::consumes.
enum class MeasurementKind : uint32_t {
  kOdometry = 1u << 0,
  kImu = 1u << 1,
  kLaserScan = 1u << 2,
  kPointCloud = 1u << 3,
  kImage = 1u << 4,
  kLandmarkDetections = 1u << 5,
};
constexpr uint32_t kAllMeasurementKinds = (1u << 6) - 1;

MeasurementKind kind_of(const Measurement& m);
const char* kind_name(MeasurementKind k);  // "odometry", "imu", "scan", ...
std::vector<std::string> kind_names(uint32_t mask);
const Header& header_of(const Measurement& m);

// ------------------------------------------------------------------- outputs

// Pose of base_link in the map frame; covariance over (x, y, z, roll, pitch, yaw).
struct PoseEstimate {
  Header header;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Matrix6d covariance = Matrix6d::Identity();
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();
};

// Named float layer on a regular grid; row-major, row 0 at origin.y(); NaN = unknown.
struct GridLayer {
  std::string layer;
  double resolution = 1.0;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  int width = 0;
  int height = 0;
  std::vector<float> cells;
};

struct MapFeature {
  std::string id;
  std::string kind;  // "line", "corner", "edge", or a landmark class
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
};

struct Particle2D {
  double x = 0, y = 0, yaw = 0, weight = 0;
};

struct AssociationRecord {
  uint32_t measurement = 0;
  std::string feature_id;  // empty = not associated
  uint32_t candidates = 0;
  double mahalanobis2 = 0.0;
};

struct Diagnostics {
  std::vector<std::pair<std::string, double>> values;
  std::vector<Particle2D> particles;
  std::vector<AssociationRecord> associations;
  bool empty() const { return values.empty() && particles.empty() && associations.empty(); }
};

// Where a plugin that explores wants the robot to go next (map frame; heading = the direction
// of travel), or done = nothing left worth scanning. score is the plugin's own utility.
struct ExplorationGoal {
  Header header;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  double score = 0.0;
  bool done = false;
};

// A plugin's own judgement of its estimate, published on the status topic. Each plugin's README
// documents its criteria (innovation statistics, effective sample size, belief modes, registration
// residual and conditioning).
enum class LocalizationState {
  kUnknown,    // the plugin does not judge
  kTracking,   // pose and covariance can be used
  kUncertain,  // several hypotheses, or a covariance the plugin cannot vouch for
  kLost,       // do not use the pose
};
const char* localization_state_name(LocalizationState state);  // "unknown", "tracking", ...

struct LocalizationAssessment {
  LocalizationState state = LocalizationState::kUnknown;
  std::string reason;  // the criterion that decided it, e.g. "effective sample size 3 % < 10 %"
};

// What one update returns. A plugin sets estimate when it has a pose to publish
// (e.g. a filter that only predicted on odometry may leave it empty to save bandwidth).
struct UpdateResult {
  std::optional<PoseEstimate> estimate;
  Diagnostics diagnostics;
  std::optional<GridLayer> grid;                 // belief, elevation, ...
  std::optional<PointCloud> map_cloud;           // registered map, map frame
  std::optional<std::vector<MapFeature>> landmark_map;
  std::optional<ExplorationGoal> exploration_goal;  // exploring plugins only
  std::optional<LocalizationAssessment> localization;  // set when the plugin judged this update
};

}  // namespace locd
