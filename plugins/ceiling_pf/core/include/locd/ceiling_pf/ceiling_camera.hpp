// An upward-looking pinhole camera under a flat ceiling: pixel -> range, azimuth and elevation
// of the ceiling point (paper eq. 1-3), and -> the point's horizontal position in base_link.
//
// Image axes: u to the right (columns), v down (rows), both from the principal point. With the
// camera's mount yaw 0 the image's top edge (-v) looks along base_link +x and its right edge
// (+u) along +y, so the paper's azimuth atan2(u, -v) is a counter-clockwise bearing.
#pragma once

#include <Eigen/Core>

#include "locd/ceiling_pf/config.hpp"

namespace locd::ceiling_pf {

// Eq. (1)-(3) for one pixel.
struct CeilingRay {
  double slant_range = 0.0;  // P, m, lens to ceiling point
  double azimuth = 0.0;      // theta, rad, counter-clockwise from the image's top edge
  double elevation = 0.0;    // phi, rad, above the horizontal
  double horizontal_range() const;  // P cos(phi)
};

class CeilingCamera {
 public:
  CeilingCamera(const CameraIntrinsics& intrinsics, const CameraMounting& mounting, double ceiling_height);

  // Eq. (1)-(3), with u, v normalised by fx, fy (so f = 1 when fx != fy).
  CeilingRay ray(double column, double row) const;
  // The ceiling point seen at a pixel, horizontal position in base_link.
  Eigen::Vector2d ceiling_point_in_base(double column, double row) const;
  // Inverse: where a ceiling point given in base_link appears in the image (column, row).
  Eigen::Vector2d project(const Eigen::Vector2d& point_in_base) const;

  double lens_to_ceiling() const { return lens_to_ceiling_; }  // h
  const CameraIntrinsics& intrinsics() const { return intrinsics_; }
  const CameraMounting& mounting() const { return mounting_; }
  // Largest horizontal distance from base_link origin to a ceiling point in view (image corners).
  double max_view_range() const;

 private:
  CameraIntrinsics intrinsics_;
  CameraMounting mounting_;
  double lens_to_ceiling_;
};

}  // namespace locd::ceiling_pf
