// A world that differs from its map (issue 22): the scenario's `differences` section, for any world
// kind (walls of a feature map or a map_server grid). The plugin still gets the map; the laser sees
// the map's world changed as listed, all in the map frame (m, degrees):
//
//   differences:
//     map_scale: 1.002                  # the world is this much larger than its map drawn
//     clutter:                          # unmapped boxes (carts, chairs, pallets)
//       - {centre: [10, 1.6], size: [0.6, 0.4], yaw_deg: 20}
//     people:                           # discs walking their path back and forth
//       - {path: [[5, 0.5], [20, 1.5]], radius: 0.25, speed: 1.0, start_s: 0}
//     walls:                            # walls the world has and the map lacks, or holds only in part
//       - [[12, 0], [12, 1.2]]
//     doors:                            # world: open  -> closed in the map, open in the world
//       - {from: [x, y], to: [x, y], world: open, thickness: 0.3}   # closed -> the other way round
//     glass:                            # a wall the map has and the laser sees through
//       - {from: [x, y], to: [x, y], thickness: 0.3}
//
// An open door or glass is a see-through band: the rectangle `thickness` wide centred on from-to
// in which the map's surfaces do not stop a beam (wide enough to hold the map's wall: a grid's wall
// cells stand up to a cell off the line). What the section adds (clutter, people, walls, closed
// doors) stops a beam wherever it is. Errors name the key, the value and what is allowed.
//
// The robot's truth stays in the map frame (where it is scored and where the plugin's answer is
// right), and the world is the map's (with everything above) scaled by map_scale: every range is
// map_scale times the map's. A map shifted or turned as a whole by a little is not a difference a
// localizer can see (the right answer moves with it), so there is no key for it; a map whose parts
// are shifted against each other (a SLAM map's drift) is not modelled yet.
#pragma once

#include <memory>
#include <vector>

#include "locd/sdk/params.hpp"
#include "locd/sim/world.hpp"

namespace locd::sim {

struct Box {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d size = Eigen::Vector2d::Ones();  // along its own x and y
  double yaw = 0.0;                                // rad
  std::vector<Segment> edges() const;
};

struct Person {
  std::vector<Eigen::Vector2d> path;  // walked from the first point to the last and back
  double radius = 0.25;               // m
  double speed = 1.0;                 // m/s
  double start_s = 0.0;               // how far along (s of walking) at t = 0
  Eigen::Vector2d at(double t) const;
};

// A band the map's surfaces do not stop a beam in: `thickness` wide around a to b.
struct SeeThrough {
  Segment along;
  double thickness = 0.3;
  bool contains(const Eigen::Vector2d& p) const;
  // Where a ray from origin along direction (unit) leaves the band, if it is in it at t.
  double exit(const Eigen::Vector2d& origin, const Eigen::Vector2d& direction, double t) const;
};

struct WorldDifferences {
  double map_scale = 1.0;
  std::vector<Box> clutter;
  std::vector<Person> people;
  std::vector<Segment> walls;        // the section's walls and the doors closed in the world
  std::vector<SeeThrough> see_through;  // glass and the doors open in the world
};

// The `differences` section (p is that section).
WorldDifferences parse_world_differences(const Params& p);

class DifferentWorld : public RangeWorld {
 public:
  DifferentWorld(std::shared_ptr<const RangeWorld> map_world, WorldDifferences differences);
  std::optional<double> cast(const Eigen::Vector2d& origin, double angle, double max_range) const override;
  std::optional<double> cast_at(double t, const Eigen::Vector2d& origin, double angle, double max_range) const override;
  const WorldDifferences& differences() const { return differences_; }

 private:
  // The map's world with the see-through bands taken out (map frame).
  std::optional<double> cast_map(const Eigen::Vector2d& origin, double angle, double max_range) const;
  std::shared_ptr<const RangeWorld> map_world_;
  WorldDifferences differences_;
  std::unique_ptr<SegmentWorld> added_;  // clutter edges, walls, closed doors
};

}  // namespace locd::sim
