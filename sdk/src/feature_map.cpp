#include "locd/sdk/feature_map.hpp"

#include <cmath>

namespace locd {

double LineFeature::alpha() const {
  const Eigen::Vector2d d = b - a;
  Eigen::Vector2d n(-d.y(), d.x());
  n.normalize();
  if (n.dot(a) < 0) n = -n;
  return std::atan2(n.y(), n.x());
}

double LineFeature::rho() const {
  const Eigen::Vector2d d = b - a;
  Eigen::Vector2d n(-d.y(), d.x());
  n.normalize();
  return std::abs(n.dot(a));
}

namespace {

Eigen::Vector2d point_of(const Params& p, const std::string& key, const YAML::Node& n, size_t i) {
  if (!n.IsSequence() || n.size() != 2) p.fail(key, "entry " + std::to_string(i) + " is not a point [x, y]");
  double x = 0, y = 0;
  if (!YAML::convert<double>::decode(n[0], x) || !YAML::convert<double>::decode(n[1], y) ||
      !std::isfinite(x) || !std::isfinite(y)) {
    p.fail(key, "entry " + std::to_string(i) + " is not a point of two finite numbers");
  }
  return {x, y};
}

}  // namespace

FeatureMap2D parse_feature_map(const Params& params, size_t max_features) {
  params.expect_only({"frame_id", "walls", "closed", "lines", "corners", "edges"});
  FeatureMap2D map;
  map.frame_id = params.text("frame_id", "map");
  auto grow = [&](size_t count) {
    if (map.size() + count > max_features) {
      params.fail("walls", "makes more than " + std::to_string(max_features) + " features (limit max_map_features)");
    }
  };
  const YAML::Node& root = params.node();
  const YAML::Node walls = root["walls"];
  const YAML::Node closed = root["closed"];
  if (walls && !walls.IsSequence()) params.fail("walls", "is not a list of polylines");
  for (size_t w = 0; walls && w < walls.size(); ++w) {
    const YAML::Node poly = walls[w];
    if (!poly.IsSequence() || poly.size() < 2) params.fail("walls", "wall " + std::to_string(w) + " needs at least 2 points");
    grow(2 * poly.size());
    std::vector<Eigen::Vector2d> pts;
    for (size_t i = 0; i < poly.size(); ++i) pts.push_back(point_of(params, "walls", poly[i], i));
    bool is_closed = false;
    if (closed && closed.IsSequence() && w < closed.size()) is_closed = closed[w].as<bool>(false);
    const size_t segments = is_closed ? pts.size() : pts.size() - 1;
    for (size_t i = 0; i < segments; ++i) {
      const auto& a = pts[i];
      const auto& b = pts[(i + 1) % pts.size()];
      if ((b - a).norm() < 1e-6) params.fail("walls", "wall " + std::to_string(w) + " has a zero-length segment");
      map.lines.push_back({"w" + std::to_string(w) + "l" + std::to_string(i), a, b});
    }
    for (size_t i = 0; i < pts.size(); ++i) {
      const bool end = !is_closed && (i == 0 || i + 1 == pts.size());
      const std::string id = "w" + std::to_string(w) + "p" + std::to_string(i);
      (end ? map.edges : map.corners).push_back({id, pts[i]});
    }
  }
  for (const char* key : {"lines", "corners", "edges"}) {
    const YAML::Node list = root[key];
    if (!list) continue;
    if (!list.IsSequence()) params.fail(key, "is not a list");
    grow(list.size());
    for (size_t i = 0; i < list.size(); ++i) {
      if (std::string(key) == "lines") {
        const YAML::Node n = list[i];
        if (!n.IsSequence() || n.size() != 4) params.fail(key, "entry " + std::to_string(i) + " is not [x1, y1, x2, y2]");
        YAML::Node a, b;
        a.push_back(n[0]); a.push_back(n[1]);
        b.push_back(n[2]); b.push_back(n[3]);
        map.lines.push_back({"L" + std::to_string(i), point_of(params, key, a, i), point_of(params, key, b, i)});
      } else {
        auto& target = std::string(key) == "corners" ? map.corners : map.edges;
        target.push_back({std::string(key) == "corners" ? "C" + std::to_string(i) : "E" + std::to_string(i),
                          point_of(params, key, list[i], i)});
      }
    }
  }
  if (map.size() == 0) params.fail("walls", "is missing; the map has no features");
  return map;
}

FeatureMap2D load_feature_map(const std::string& file, size_t max_features) {
  return parse_feature_map(Params::load_file(file), max_features);
}

}  // namespace locd
