// An indoor world for 3D scanning: axis-aligned boxes (walls, floor, ceiling, doors' lintels,
// furniture), each with a reflectivity, and people walking back and forth between two points.
// Rays are cast exactly against every box (slab test); a building has tens of boxes, so a
// 100k-ray scan costs a few million slab tests.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "locd/sdk/params.hpp"

namespace locd::sim {

struct SurfaceBox {
  Eigen::AlignedBox3d box;
  float reflectivity = 0.5f;  // [0, 1], what the scanner reports as intensity on this surface
  std::string label;          // "wall", "floor", "table", ...
};

// A person walks from `from` to `to` and back at `speed`, as a box of `size` standing on the floor.
struct WalkingPerson {
  Eigen::Vector2d from = Eigen::Vector2d::Zero();
  Eigen::Vector2d to = Eigen::Vector2d::Zero();
  double speed = 0.8;                                    // m/s
  Eigen::Vector3d size = Eigen::Vector3d(0.5, 0.4, 1.7);  // m
  float reflectivity = 0.4f;

  Eigen::AlignedBox3d box_at(double t) const;
};

struct RayHit {
  double range = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit normal of the face hit, against the ray
  float reflectivity = 0.0f;
  int object = -1;  // index into boxes(), or boxes().size() + person index for a person
};

// Distance along origin + t * direction to the box's surface (entering face; t >= 0), with the
// face's outward normal. nullopt when the ray misses or starts inside the box.
std::optional<std::pair<double, Eigen::Vector3d>> ray_box_entry(const Eigen::Vector3d& origin,
                                                                 const Eigen::Vector3d& direction,
                                                                 const Eigen::AlignedBox3d& box);

class IndoorWorld {
 public:
  IndoorWorld(std::vector<SurfaceBox> boxes, std::vector<WalkingPerson> people);

  // YAML: `boxes: [{min: [x,y,z], max: [x,y,z], reflectivity, label}]`,
  // `people: [{from: [x,y], to: [x,y], speed, size: [sx,sy,sz], reflectivity}]`.
  static IndoorWorld from_params(const Params& params);
  static IndoorWorld load(const std::filesystem::path& file);

  // First surface along the ray at time t (people where they are at t), within max_range.
  std::optional<RayHit> cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double max_range,
                             double t) const;

  // True when p lies inside a static box (walls, furniture) or outside the bounds.
  bool inside_static(const Eigen::Vector3d& p) const;
  // Distance from p to the nearest static box (0 inside one): how far a model point is from any
  // real surface (a ghost of a person stands off every wall and piece of furniture).
  double distance_to_static(const Eigen::Vector3d& p) const;
  // The free-standing clearance test used to place robots: the disc of `radius` at the robot's
  // footprint between heights [z_low, z_high] touches no static box.
  bool footprint_free(const Eigen::Vector2d& xy, double radius, double z_low, double z_high) const;

  const std::vector<SurfaceBox>& boxes() const { return boxes_; }
  const std::vector<WalkingPerson>& people() const { return people_; }
  const Eigen::AlignedBox3d& bounds() const { return bounds_; }

 private:
  std::vector<SurfaceBox> boxes_;
  std::vector<WalkingPerson> people_;
  Eigen::AlignedBox3d bounds_;
};

}  // namespace locd::sim
