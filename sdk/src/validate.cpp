#include "locd/sdk/validate.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <string>

#include "locd/sdk/errors.hpp"

namespace locd {
namespace {

bool finite(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

// Below this norm a quaternion has no direction to normalise to.
constexpr double kMinQuaternionNorm = 1e-6;

// Intensities come one per range (point) or not at all.
void check_intensities(const char* topic, size_t intensities, size_t items, const char* items_name,
                       const char* item_name) {
  if (intensities != 0 && intensities != items) {
    throw InputError(std::string(topic) + ": " + std::to_string(intensities) + " intensities for " +
                     std::to_string(items) + " " + items_name + "; send none or one per " + item_name);
  }
}

}  // namespace

void check_limit(const char* topic, const char* what, size_t count, size_t limit, const char* key) {
  if (count > limit) {
    throw InputError(std::string(topic) + ": " + std::to_string(count) + " " + what + " exceed the limit " + key +
                     " = " + std::to_string(limit));
  }
}

void validate(const Odometry& odometry) {
  if (!finite(odometry.pose)) throw InputError("odometry: pose has a NaN or infinite component");
  if (!odometry.linear_velocity.allFinite() || !odometry.angular_velocity.allFinite()) {
    throw InputError("odometry: velocity is NaN or infinite");
  }
}

void validate(const Imu& imu) {
  if (!imu.orientation.coeffs().allFinite()) throw InputError("imu: orientation (attitude) is NaN or infinite");
  if (imu.orientation.norm() < kMinQuaternionNorm) throw InputError("imu: orientation is a zero quaternion");
  if (!imu.angular_velocity.allFinite() || !imu.linear_acceleration.allFinite()) {
    throw InputError("imu: angular velocity or acceleration is NaN or infinite");
  }
}

void validate(const LaserScan& scan) {
  if (scan.ranges.empty()) throw InputError("scan: empty (0 beams)");
  check_intensities("scan", scan.intensities.size(), scan.ranges.size(), "ranges", "range");
  if (!std::isfinite(scan.angle_min) || !std::isfinite(scan.angle_increment) || scan.angle_increment == 0.0f ||
      !std::isfinite(scan.range_min) || !std::isfinite(scan.range_max) || !(scan.range_max > scan.range_min)) {
    throw InputError("scan: angle_min, angle_increment (non-zero), range_min < range_max must be finite");
  }
  if (!finite(scan.sensor_pose)) throw InputError("scan sensor_pose: pose has a NaN or infinite component");
  for (size_t i = 0; i < scan.ranges.size(); ++i) {
    if (scan.valid_return(i)) return;
  }
  throw InputError("scan: no beam is a return (a range r with range_min <= r < range_max)");
}

void validate(const PointCloud& cloud) {
  if (cloud.points.empty()) throw InputError("cloud: empty (0 points)");
  check_intensities("cloud", cloud.intensity.size(), cloud.points.size(), "points", "point");
  if (!finite(cloud.sensor_pose)) throw InputError("cloud sensor_pose: pose has a NaN or infinite component");
  for (const Eigen::Vector3f& p : cloud.points) {
    if (p.allFinite()) return;  // NaN points are "no return"; one real point makes a cloud
  }
  throw InputError("cloud: every point is NaN or infinite");
}

void validate(const Image& image) {
  if (image.width <= 0 || image.height <= 0) throw InputError("image: width and height must be positive");
  if (image.channels != 1 && image.channels != 3) {
    throw InputError("image: " + std::to_string(image.channels) + " channels; allowed: 1 (mono8), 3 (bgr8)");
  }
  const size_t expected = static_cast<size_t>(image.width) * static_cast<size_t>(image.height) * image.channels;
  if (image.data.size() != expected) {
    throw InputError("image: " + std::to_string(image.data.size()) +
                     " bytes of data, expected width * height * channels = " + std::to_string(expected));
  }
}

void validate(const LandmarkDetections& frame) {
  for (size_t i = 0; i < frame.detections.size(); ++i) {
    const LandmarkDetection& d = frame.detections[i];
    if (!d.position.allFinite()) {
      throw InputError("detections: detection " + std::to_string(i) + " has a NaN or infinite position");
    }
    if (!d.covariance.allFinite()) throw InputError("detections: detection " + std::to_string(i) + " has a NaN covariance");
  }
}

void validate(const Measurement& measurement) {
  std::visit([](const auto& m) { validate(m); }, measurement);
}

void validate(const PoseEstimate& estimate) {
  // Tolerances for a rotation that went through float arithmetic, and for rounding in a
  // covariance: relative to its largest entry (at least 1).
  constexpr double kRotationTolerance = 1e-6;
  constexpr double kCovarianceTolerance = 1e-9;
  if (!finite(estimate.pose)) throw InputError("estimate: pose has a NaN or infinite component");
  const Eigen::Matrix3d R = estimate.pose.linear();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > kRotationTolerance ||
      R.determinant() < 0.0) {
    throw InputError("estimate: the pose's rotation is not a rotation (not orthonormal with determinant 1)");
  }
  const Matrix6d& C = estimate.covariance;
  if (!C.allFinite()) throw InputError("estimate: covariance has a NaN or infinite entry");
  const double scale = std::max(1.0, C.cwiseAbs().maxCoeff());
  if ((C - C.transpose()).cwiseAbs().maxCoeff() > kCovarianceTolerance * scale) {
    throw InputError("estimate: covariance is not symmetric");
  }
  const double smallest = Eigen::SelfAdjointEigenSolver<Matrix6d>(C, Eigen::EigenvaluesOnly).eigenvalues()(0);
  if (smallest < -kCovarianceTolerance * scale) {
    throw InputError("estimate: covariance is not positive semi-definite (smallest eigenvalue " +
                     std::to_string(smallest) + ")");
  }
  if (!estimate.linear_velocity.allFinite()) throw InputError("estimate: velocity is NaN or infinite");
}

}  // namespace locd
