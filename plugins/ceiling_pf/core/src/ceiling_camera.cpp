#include "locd/ceiling_pf/ceiling_camera.hpp"

#include <algorithm>
#include <cmath>
#include "locd/sdk/errors.hpp"

namespace locd::ceiling_pf {

double CeilingRay::horizontal_range() const { return slant_range * std::cos(elevation); }

CeilingCamera::CeilingCamera(const CameraIntrinsics& intrinsics, const CameraMounting& mounting,
                             double ceiling_height)
    : intrinsics_(intrinsics), mounting_(mounting), lens_to_ceiling_(ceiling_height - mounting.height) {
  if (!(lens_to_ceiling_ > 0.0)) {
    throw ConfigError("ceiling_pf: the ceiling height must be above the camera lens");
  }
}

CeilingRay CeilingCamera::ray(double column, double row) const {
  const double u = (column - intrinsics_.cx) / intrinsics_.fx;
  const double v = (row - intrinsics_.cy) / intrinsics_.fy;
  const double f = 1.0;
  const double h = lens_to_ceiling_;
  CeilingRay r;
  r.slant_range = std::sqrt(u * u + v * v + f * f) * h / f;  // eq. (1)
  r.azimuth = std::atan2(u, -v);                              // eq. (2)
  r.elevation = std::atan2(f, std::sqrt(u * u + v * v));      // eq. (3)
  return r;
}

Eigen::Vector2d CeilingCamera::ceiling_point_in_base(double column, double row) const {
  const CeilingRay r = ray(column, row);
  const double range = r.horizontal_range();
  const double a = r.azimuth + mounting_.yaw;
  return {mounting_.x + range * std::cos(a), mounting_.y + range * std::sin(a)};
}

Eigen::Vector2d CeilingCamera::project(const Eigen::Vector2d& point_in_base) const {
  const double c = std::cos(mounting_.yaw), s = std::sin(mounting_.yaw);
  const double dx = point_in_base.x() - mounting_.x, dy = point_in_base.y() - mounting_.y;
  const double forward = c * dx + s * dy;  // along the image's top edge
  const double left = -s * dx + c * dy;    // along the image's right edge
  return {intrinsics_.cx + intrinsics_.fx * left / lens_to_ceiling_,
          intrinsics_.cy - intrinsics_.fy * forward / lens_to_ceiling_};
}

double CeilingCamera::max_view_range() const {
  double best = 0.0;
  for (double col : {-0.5, intrinsics_.width - 0.5}) {
    for (double row : {-0.5, intrinsics_.height - 0.5}) {
      best = std::max(best, ceiling_point_in_base(col, row).norm());
    }
  }
  return best;
}

}  // namespace locd::ceiling_pf
