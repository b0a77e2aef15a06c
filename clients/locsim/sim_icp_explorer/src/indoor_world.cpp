#include "locd/sim_icp_explorer/indoor_world.hpp"

#include <cmath>
#include <algorithm>
#include <limits>

#include "locd/sdk/errors.hpp"

namespace locd::sim {

Eigen::AlignedBox3d WalkingPerson::box_at(double t) const {
  const double length = (to - from).norm();
  Eigen::Vector2d centre = from;
  if (length > 1e-9 && speed > 0) {
    const double period = 2.0 * length / speed;
    double s = std::fmod(std::max(t, 0.0), period) * speed;  // distance walked in this period
    if (s > length) s = 2.0 * length - s;
    centre = from + (to - from) * (s / length);
  }
  const Eigen::Vector3d half(size.x() / 2, size.y() / 2, 0.0);
  const Eigen::Vector3d base(centre.x(), centre.y(), 0.0);
  return Eigen::AlignedBox3d(base - half, base + half + Eigen::Vector3d(0, 0, size.z()));
}

std::optional<std::pair<double, Eigen::Vector3d>> ray_box_entry(const Eigen::Vector3d& origin,
                                                                 const Eigen::Vector3d& direction,
                                                                 const Eigen::AlignedBox3d& box) {
  double t_enter = -std::numeric_limits<double>::infinity();
  double t_exit = std::numeric_limits<double>::infinity();
  int enter_axis = -1;
  double enter_sign = 0.0;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(direction[a]) < 1e-15) {
      if (origin[a] < box.min()[a] || origin[a] > box.max()[a]) return std::nullopt;
      continue;
    }
    const double inv = 1.0 / direction[a];
    double t0 = (box.min()[a] - origin[a]) * inv;
    double t1 = (box.max()[a] - origin[a]) * inv;
    double sign = -1.0;  // entering through the min face: outward normal -axis
    if (t0 > t1) {
      std::swap(t0, t1);
      sign = 1.0;
    }
    if (t0 > t_enter) {
      t_enter = t0;
      enter_axis = a;
      enter_sign = sign;
    }
    t_exit = std::min(t_exit, t1);
    if (t_enter > t_exit) return std::nullopt;
  }
  if (enter_axis < 0 || t_enter < 0.0) return std::nullopt;  // starts inside or behind
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  normal[enter_axis] = enter_sign;
  return std::make_pair(t_enter, normal);
}

IndoorWorld::IndoorWorld(std::vector<SurfaceBox> boxes, std::vector<WalkingPerson> people)
    : boxes_(std::move(boxes)), people_(std::move(people)) {
  for (const auto& b : boxes_) bounds_.extend(b.box);
}

namespace {
Eigen::Vector3d vector3(const Params& p, const std::string& key) {
  const auto v = p.numbers(key, {}, 3);
  return {v[0], v[1], v[2]};
}
}  // namespace

IndoorWorld IndoorWorld::from_params(const Params& params) {
  params.expect_only({"frame_id", "boxes", "people"});
  std::vector<SurfaceBox> boxes;
  std::vector<WalkingPerson> people;
  const YAML::Node& list = params.node()["boxes"];
  if (!list || !list.IsSequence() || list.size() == 0) params.fail("boxes", "must be a non-empty list of boxes");
  for (size_t i = 0; i < list.size(); ++i) {
    const Params b(list[i], params.key_path("boxes") + "[" + std::to_string(i) + "]");
    b.expect_only({"min", "max", "reflectivity", "label"});
    SurfaceBox box;
    box.box = Eigen::AlignedBox3d(vector3(b, "min"), vector3(b, "max"));
    if ((box.box.max() - box.box.min()).minCoeff() <= 0.0) b.fail("max", "must exceed min on every axis");
    box.reflectivity = static_cast<float>(b.number("reflectivity", 0.5, Range::closed(0.0, 1.0)));
    box.label = b.text("label", "box");
    boxes.push_back(box);
  }
  const YAML::Node& walkers = params.node()["people"];
  if (walkers && walkers.IsSequence()) {
    for (size_t i = 0; i < walkers.size(); ++i) {
      const Params w(walkers[i], params.key_path("people") + "[" + std::to_string(i) + "]");
      w.expect_only({"from", "to", "speed", "size", "reflectivity"});
      WalkingPerson p;
      const auto from = w.numbers("from", {}, 2), to = w.numbers("to", {}, 2);
      p.from = {from[0], from[1]};
      p.to = {to[0], to[1]};
      p.speed = w.number("speed", p.speed, Range::closed(0.0, 3.0));
      const auto size = w.numbers("size", {p.size.x(), p.size.y(), p.size.z()}, 3, Range::positive());
      p.size = {size[0], size[1], size[2]};
      p.reflectivity = static_cast<float>(w.number("reflectivity", p.reflectivity, Range::closed(0.0, 1.0)));
      people.push_back(p);
    }
  }
  return IndoorWorld(std::move(boxes), std::move(people));
}

IndoorWorld IndoorWorld::load(const std::filesystem::path& file) {
  return from_params(Params::load_file(file.string()));
}

std::optional<RayHit> IndoorWorld::cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                        double max_range, double t) const {
  RayHit best;
  best.range = max_range;
  auto consider = [&](const Eigen::AlignedBox3d& box, float reflectivity, int object) {
    const auto hit = ray_box_entry(origin, direction, box);
    if (hit && hit->first < best.range) {
      best.range = hit->first;
      best.normal = hit->second;
      best.reflectivity = reflectivity;
      best.object = object;
    }
  };
  for (size_t i = 0; i < boxes_.size(); ++i) consider(boxes_[i].box, boxes_[i].reflectivity, static_cast<int>(i));
  for (size_t i = 0; i < people_.size(); ++i)
    consider(people_[i].box_at(t), people_[i].reflectivity, static_cast<int>(boxes_.size() + i));
  if (best.object < 0) return std::nullopt;
  return best;
}

bool IndoorWorld::inside_static(const Eigen::Vector3d& p) const {
  if (!bounds_.contains(p)) return true;
  for (const auto& b : boxes_)
    if (b.box.contains(p)) return true;
  return false;
}

double IndoorWorld::distance_to_static(const Eigen::Vector3d& p) const {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& b : boxes_) best = std::min(best, b.box.exteriorDistance(p));
  return best;
}

bool IndoorWorld::footprint_free(const Eigen::Vector2d& xy, double radius, double z_low, double z_high) const {
  const Eigen::AlignedBox3d footprint(Eigen::Vector3d(xy.x() - radius, xy.y() - radius, z_low),
                                      Eigen::Vector3d(xy.x() + radius, xy.y() + radius, z_high));
  if (!bounds_.contains(footprint)) return false;
  for (const auto& b : boxes_)
    if (b.box.intersects(footprint)) return false;
  return true;
}

}  // namespace locd::sim
