#include "locd/sim/world_differences.hpp"

#include <cmath>
#include <functional>
#include <limits>

namespace locd::sim {

namespace {

constexpr double kCoordinateLimit = 1e6;  // m

Eigen::Vector2d rotate(const Eigen::Vector2d& v, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
}

Eigen::Vector2d point_of(const Params& p, const std::string& key) {
  if (!p.has(key)) p.fail(key, "is missing; expected a point [x, y] in m");
  const auto v = p.numbers(key, {}, 2, Range::closed(-kCoordinateLimit, kCoordinateLimit));
  return {v[0], v[1]};
}

// The points of a list [[x, y], ...] (node), at least `minimum` of them, none repeating the last.
std::vector<Eigen::Vector2d> points_of(const Params& p, const std::string& key, const YAML::Node& list, size_t minimum,
                                       const std::string& expected) {
  if (!list || !list.IsSequence() || list.size() < minimum) p.fail(key, "is not " + expected);
  std::vector<Eigen::Vector2d> points;
  for (size_t i = 0; i < list.size(); ++i) {
    double x = 0, y = 0;
    const YAML::Node n = list[i];
    if (!n.IsSequence() || n.size() != 2 || !YAML::convert<double>::decode(n[0], x) ||
        !YAML::convert<double>::decode(n[1], y) || !std::isfinite(x) || !std::isfinite(y) ||
        std::abs(x) > kCoordinateLimit || std::abs(y) > kCoordinateLimit) {
      p.fail(key, "point " + std::to_string(i) + " is not [x, y] of two finite numbers within 1e6 m; expected " +
                      expected);
    }
    if (!points.empty() && (Eigen::Vector2d(x, y) - points.back()).norm() < 1e-3) {
      p.fail(key, "point " + std::to_string(i) + " repeats the previous one; expected " + expected);
    }
    points.emplace_back(x, y);
  }
  return points;
}

// Calls entry(params of entry i) for each map in the list under key.
void for_each_entry(const Params& p, const std::string& key, const std::string& expected,
                    const std::function<void(const Params&)>& entry) {
  if (!p.has(key)) return;
  const YAML::Node list = p.node()[key];
  if (!list.IsSequence()) p.fail(key, "is not a list; expected a list of " + expected);
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string index = "[" + std::to_string(i) + "]";
    if (!list[i].IsMap()) p.fail(key, "entry " + std::to_string(i) + " is not a map; expected " + expected);
    entry(Params(list[i], p.key_path(key) + index));
  }
}

Segment segment_of(const Params& e) {
  Segment s{point_of(e, "from"), point_of(e, "to")};
  if ((s.b - s.a).norm() < 1e-3) e.fail("to", "is where `from` is; expected a segment at least 1 mm long");
  return s;
}

}  // namespace

std::vector<Segment> Box::edges() const {
  const Eigen::Vector2d h = size / 2.0;
  const Eigen::Vector2d corners[4] = {centre + rotate({-h.x(), -h.y()}, yaw), centre + rotate({h.x(), -h.y()}, yaw),
                                      centre + rotate({h.x(), h.y()}, yaw), centre + rotate({-h.x(), h.y()}, yaw)};
  return {{corners[0], corners[1]}, {corners[1], corners[2]}, {corners[2], corners[3]}, {corners[3], corners[0]}};
}

Eigen::Vector2d Person::at(double t) const {
  double length = 0.0;
  for (size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  if (length <= 0.0) return path.front();
  double s = std::fmod(speed * (t + start_s), 2.0 * length);
  if (s < 0.0) s += 2.0 * length;
  if (s > length) s = 2.0 * length - s;  // on the way back
  for (size_t i = 1; i < path.size(); ++i) {
    const double piece = (path[i] - path[i - 1]).norm();
    if (s <= piece) return path[i - 1] + (path[i] - path[i - 1]) * (s / piece);
    s -= piece;
  }
  return path.back();
}

bool SeeThrough::contains(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d axis = along.b - along.a;
  const double length = axis.norm();
  const Eigen::Vector2d u = axis / length, w = p - along.a;
  const double x = w.dot(u), y = u.x() * w.y() - u.y() * w.x();
  constexpr double kSlack = 1e-9;
  return x >= -kSlack && x <= length + kSlack && std::abs(y) <= thickness / 2.0 + kSlack;
}

double SeeThrough::exit(const Eigen::Vector2d& origin, const Eigen::Vector2d& direction, double t) const {
  const Eigen::Vector2d axis = along.b - along.a;
  const double length = axis.norm();
  const Eigen::Vector2d u = axis / length, w = origin - along.a;
  // The ray in the band's frame: x along from-to in [0, length], y across in [-thickness/2, thickness/2].
  const double x0 = w.dot(u), y0 = u.x() * w.y() - u.y() * w.x();
  const double dx = direction.dot(u), dy = u.x() * direction.y() - u.y() * direction.x();
  double out = std::numeric_limits<double>::infinity();
  if (std::abs(dx) > 1e-12) out = std::min(out, std::max((0.0 - x0) / dx, (length - x0) / dx));
  if (std::abs(dy) > 1e-12) out = std::min(out, std::max((-thickness / 2 - y0) / dy, (thickness / 2 - y0) / dy));
  return std::max(out, t);
}

WorldDifferences parse_world_differences(const Params& p) {
  p.expect_only({"map_scale", "clutter", "people", "walls", "doors", "glass"});
  WorldDifferences d;
  d.map_scale = p.number("map_scale", 1.0, Range::closed(0.9, 1.1));
  for_each_entry(p, "clutter", "boxes {centre: [x, y], size: [length, width], yaw_deg}", [&](const Params& e) {
    e.expect_only({"centre", "size", "yaw_deg"});
    Box b;
    b.centre = point_of(e, "centre");
    if (!e.has("size")) e.fail("size", "is missing; expected [length, width] in m");
    const auto size = e.numbers("size", {}, 2, Range{0.0, 100.0, true, false});
    b.size = {size[0], size[1]};
    b.yaw = e.number("yaw_deg", 0.0, Range::closed(-360.0, 360.0)) * M_PI / 180.0;
    d.clutter.push_back(b);
  });
  for_each_entry(p, "people", "people {path: [[x, y], ...], radius, speed, start_s}", [&](const Params& e) {
    e.expect_only({"path", "radius", "speed", "start_s"});
    Person person;
    person.path = points_of(e, "path", e.node()["path"], 1, "a list of at least one point [[x, y], ...]");
    person.radius = e.number("radius", person.radius, Range{0.0, 5.0, true, false});
    person.speed = e.number("speed", person.speed, Range::closed(0.0, 10.0));
    person.start_s = e.number("start_s", person.start_s, Range::closed(0.0, 1e6));
    d.people.push_back(person);
  });
  if (p.has("walls")) {
    const YAML::Node list = p.node()["walls"];
    if (!list.IsSequence()) p.fail("walls", "is not a list; expected a list of walls [[x, y], [x, y]]");
    for (size_t i = 0; i < list.size(); ++i) {
      const auto ends = points_of(p, "walls", list[i], 2, "a wall [[x, y], [x, y]] (entry " + std::to_string(i) + ")");
      if (ends.size() != 2) p.fail("walls", "entry " + std::to_string(i) + " has " + std::to_string(ends.size()) +
                                                " points; expected a wall [[x, y], [x, y]]");
      d.walls.push_back({ends[0], ends[1]});
    }
  }
  for_each_entry(p, "doors", "doors {from: [x, y], to: [x, y], world: open | closed, thickness}", [&](const Params& e) {
    e.expect_only({"from", "to", "world", "thickness"});
    const Segment door = segment_of(e);
    if (!e.has("world")) e.fail("world", "is missing; expected open (closed in the map) or closed (open in the map)");
    const std::string state = e.text("world", "", {"open", "closed"});
    const double thickness = e.number("thickness", 0.3, Range{0.0, 5.0, true, false});
    if (state == "open") {
      d.see_through.push_back({door, thickness});
    } else {
      d.walls.push_back(door);
    }
  });
  for_each_entry(p, "glass", "glass walls {from: [x, y], to: [x, y], thickness}", [&](const Params& e) {
    e.expect_only({"from", "to", "thickness"});
    d.see_through.push_back({segment_of(e), e.number("thickness", 0.3, Range{0.0, 5.0, true, false})});
  });
  return d;
}

DifferentWorld::DifferentWorld(std::shared_ptr<const RangeWorld> map_world, WorldDifferences differences)
    : map_world_(std::move(map_world)), differences_(std::move(differences)) {
  std::vector<Segment> added = differences_.walls;
  for (const Box& b : differences_.clutter) {
    for (const Segment& e : b.edges()) added.push_back(e);
  }
  added_ = std::make_unique<SegmentWorld>(std::move(added));
}

std::optional<double> DifferentWorld::cast(const Eigen::Vector2d& origin, double angle, double max_range) const {
  return cast_at(0.0, origin, angle, max_range);
}

std::optional<double> DifferentWorld::cast_map(const Eigen::Vector2d& origin, double angle, double max_range) const {
  const Eigen::Vector2d direction(std::cos(angle), std::sin(angle));
  double offset = 0.0;  // along the ray (m): where the cast starts again past a band
  for (int pass = 0; pass < 64; ++pass) {
    const auto range = map_world_->cast(origin + offset * direction, angle, max_range - offset);
    if (!range) return std::nullopt;
    const double t = offset + *range;
    const Eigen::Vector2d hit = origin + t * direction;
    const SeeThrough* band = nullptr;
    for (const SeeThrough& s : differences_.see_through) {
      if (s.contains(hit)) {
        band = &s;
        break;
      }
    }
    if (!band) return t;
    offset = band->exit(origin, direction, t) + 1e-6;
    if (offset > max_range) return std::nullopt;
  }
  return std::nullopt;
}

std::optional<double> DifferentWorld::cast_at(double t, const Eigen::Vector2d& origin, double angle,
                                              double max_range_world) const {
  // The world is the scene below scaled by map_scale: cast in the map's frame, scale the range.
  const double scale = differences_.map_scale, max_range = max_range_world / scale;
  std::optional<double> best = cast_map(origin, angle, max_range);
  const auto keep = [&](std::optional<double> r) {
    if (r && (!best || *r < *best)) best = r;
  };
  keep(added_->cast(origin, angle, max_range));
  const Eigen::Vector2d direction(std::cos(angle), std::sin(angle));
  for (const Person& person : differences_.people) {
    // |origin + s d - c| = r: s^2 + 2 b s + c = 0 with b = m.d, c = m.m - r^2.
    const Eigen::Vector2d m = origin - person.at(t);
    const double b = m.dot(direction), c = m.squaredNorm() - person.radius * person.radius;
    if (c > 0.0 && b > 0.0) continue;  // outside and moving away
    const double discriminant = b * b - c;
    if (discriminant < 0.0) continue;
    const double s = std::max(0.0, -b - std::sqrt(discriminant));
    if (s <= max_range) keep(s);
  }
  if (best) *best *= scale;
  return best;
}

}  // namespace locd::sim
