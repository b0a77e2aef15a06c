#include "locd/sdk/types.hpp"

#include <cmath>
#include <limits>

namespace locd {

RangeReading LaserScan::reading(size_t i) const {
  const float r = ranges[i];
  if (std::isnan(r)) return RangeReading::kInvalid;
  if (r == -std::numeric_limits<float>::infinity()) return RangeReading::kTooClose;
  if (r >= range_max) return RangeReading::kNoReturn;  // +inf included
  if (r < range_min) return RangeReading::kInvalid;
  return RangeReading::kHit;
}

MeasurementKind kind_of(const Measurement& m) {
  static constexpr MeasurementKind kinds[] = {
      MeasurementKind::kOdometry,   MeasurementKind::kImu,   MeasurementKind::kLaserScan,
      MeasurementKind::kPointCloud, MeasurementKind::kImage, MeasurementKind::kLandmarkDetections};
  return kinds[m.index()];
}

const char* kind_name(MeasurementKind k) {
  switch (k) {
    case MeasurementKind::kOdometry: return "odometry";
    case MeasurementKind::kImu: return "imu";
    case MeasurementKind::kLaserScan: return "scan";
    case MeasurementKind::kPointCloud: return "cloud";
    case MeasurementKind::kImage: return "image";
    case MeasurementKind::kLandmarkDetections: return "detections";
  }
  return "unknown";
}

std::vector<std::string> kind_names(uint32_t mask) {
  std::vector<std::string> names;
  for (uint32_t bit = 1; bit != 0 && bit <= kAllMeasurementKinds; bit <<= 1) {
    if (mask & bit) names.emplace_back(kind_name(static_cast<MeasurementKind>(bit)));
  }
  return names;
}

const char* localization_state_name(LocalizationState state) {
  switch (state) {
    case LocalizationState::kUnknown: return "unknown";
    case LocalizationState::kTracking: return "tracking";
    case LocalizationState::kUncertain: return "uncertain";
    case LocalizationState::kLost: return "lost";
  }
  return "unknown";
}

const Header& header_of(const Measurement& m) {
  return std::visit([](const auto& v) -> const Header& { return v.header; }, m);
}

}  // namespace locd
