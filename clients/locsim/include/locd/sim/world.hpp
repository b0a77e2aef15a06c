// The simulated world: what a planar laser sees along a ray. RangeWorld is the interface the
// sensors use; SegmentWorld casts exactly against wall segments (a uniform grid of cells, each
// listing the segments whose bounding box overlaps it, lets a ray visit only the cells it
// crosses, Amanatides & Woo; cast_brute_force tests every segment and is the reference);
// GridWorld (grid_world.hpp) casts on an occupancy grid.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "locd/sdk/feature_map.hpp"

namespace locd::sim {

struct Segment {
  Eigen::Vector2d a, b;
};

// Distance t >= 0 along origin + t * direction (unit) to the segment, or nullopt when the ray
// misses it or runs parallel to it.
std::optional<double> ray_segment_distance(const Eigen::Vector2d& origin, const Eigen::Vector2d& direction,
                                           const Segment& segment);

class RangeWorld {
 public:
  virtual ~RangeWorld() = default;
  // Range to the first obstacle along the ray from origin at angle (map frame), if within max_range.
  virtual std::optional<double> cast(const Eigen::Vector2d& origin, double angle, double max_range) const = 0;
  // The same at time t (s since the start) in a world with moving things (people walking).
  virtual std::optional<double> cast_at(double /*t*/, const Eigen::Vector2d& origin, double angle,
                                        double max_range) const {
    return cast(origin, angle, max_range);
  }
};

class SegmentWorld : public RangeWorld {
 public:
  explicit SegmentWorld(std::vector<Segment> segments, double cell_size_m = 1.0);
  // Every line of the map is a wall.
  static SegmentWorld from_feature_map(const FeatureMap2D& map, double cell_size_m = 1.0);

  std::optional<double> cast(const Eigen::Vector2d& origin, double angle, double max_range) const override;
  std::optional<double> cast_brute_force(const Eigen::Vector2d& origin, double angle, double max_range) const;

  const std::vector<Segment>& segments() const { return segments_; }
  const Eigen::AlignedBox2d& bounds() const { return bounds_; }

 private:
  std::vector<Segment> segments_;
  Eigen::AlignedBox2d bounds_;
  double cell_size_;
  int columns_ = 0, rows_ = 0;
  std::vector<std::vector<int>> cells_;  // row-major, segment indices
};

}  // namespace locd::sim
