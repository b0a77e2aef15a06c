#include "locd/sim_feature_ekf/road_sign_world.hpp"

#include <cmath>
#include <iomanip>
#include <random>
#include <sstream>

#include "locd/sdk/errors.hpp"

namespace locd::sim::road_signs {

namespace {
constexpr double kDegree = M_PI / 180.0;
}

WorldConfig WorldConfig::from_params(const Params& p) {
  p.expect_only({"centre", "altitude", "blocks", "block_size", "sign_offset", "min_sign_spacing", "classes", "seed"});
  WorldConfig c;
  const std::vector<double> centre = p.numbers("centre", {c.centre_latitude_deg, c.centre_longitude_deg}, 2);
  if (std::fabs(centre[0]) > 85.0 || std::fabs(centre[1]) > 180.0) {
    p.fail("centre", "is out of range; allowed: latitude [-85, 85], longitude [-180, 180] degrees");
  }
  c.centre_latitude_deg = centre[0];
  c.centre_longitude_deg = centre[1];
  c.altitude = p.number("altitude", c.altitude, Range::closed(-1000.0, 10000.0));
  const std::vector<double> blocks = p.numbers("blocks", {4.0, 4.0}, 2, Range::closed(1.0, 50.0));
  c.blocks_east = static_cast<int>(blocks[0]);
  c.blocks_north = static_cast<int>(blocks[1]);
  c.block_size = p.number("block_size", c.block_size, Range::closed(60.0, 5000.0));
  c.sign_offset = p.number("sign_offset", c.sign_offset, Range::closed(0.0, 30.0));
  c.min_sign_spacing = p.number("min_sign_spacing", c.min_sign_spacing, Range::non_negative());
  if (p.has("classes")) {
    c.classes.clear();
    const Params classes = p.child("classes");
    for (const auto& kv : classes.node()) {
      const std::string name = kv.first.as<std::string>();
      c.classes.push_back({name, static_cast<int>(classes.integer(name, 0, 1, 100000))});
    }
  }
  c.seed = static_cast<uint64_t>(p.integer("seed", static_cast<long>(c.seed), 0, 1L << 40));
  return c;
}

RoadSignWorld::RoadSignWorld(WorldConfig config) : config_(std::move(config)) {
  const double lat0 = config_.centre_latitude_deg * kDegree;
  const double e2 = 6.69437999014e-3, a = 6378137.0;
  const double w = 1.0 - e2 * std::sin(lat0) * std::sin(lat0);
  meridian_radius_ = a * (1.0 - e2) / std::pow(w, 1.5);
  transverse_radius_ = a / std::sqrt(w);

  // Road edges between adjacent intersections; a sign stands beside one direction of one edge.
  struct Edge {
    Eigen::Vector2d a, b;
  };
  std::vector<Edge> edges;
  for (int j = 0; j <= config_.blocks_north; ++j)
    for (int i = 0; i < config_.blocks_east; ++i) edges.push_back({node(i, j), node(i + 1, j)});
  for (int i = 0; i <= config_.blocks_east; ++i)
    for (int j = 0; j < config_.blocks_north; ++j) edges.push_back({node(i, j), node(i, j + 1)});

  std::mt19937_64 rng(config_.seed);
  std::uniform_int_distribution<size_t> pick_edge(0, edges.size() - 1);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const double margin = 15.0;  // m kept free near intersections
  // Per (edge, direction): positions along the edge already taken.
  std::vector<std::vector<double>> taken(2 * edges.size());
  int counter = 0;
  for (const auto& [name, count] : config_.classes) {
    for (int k = 0; k < count; ++k) {
      for (int attempt = 0; attempt < 1000; ++attempt) {
        const size_t e = pick_edge(rng);
        const int direction = uniform(rng) < 0.5 ? 0 : 1;
        const double length = (edges[e].b - edges[e].a).norm();
        const double along = margin + uniform(rng) * (length - 2 * margin);
        bool free = true;
        for (double t : taken[2 * e + direction]) free = free && std::fabs(t - along) >= config_.min_sign_spacing;
        if (!free && attempt < 999) continue;
        taken[2 * e + direction].push_back(along);
        const Eigen::Vector2d from = direction == 0 ? edges[e].a : edges[e].b;
        const Eigen::Vector2d to = direction == 0 ? edges[e].b : edges[e].a;
        const Eigen::Vector2d d = (to - from).normalized();
        const Eigen::Vector2d right(d.y(), -d.x());
        RoadSign sign;
        sign.id = "s" + std::to_string(++counter);
        sign.class_label = name;
        sign.position = from + along * d + config_.sign_offset * right;
        sign.facing = std::atan2(d.y(), d.x());
        const Eigen::Vector2d geodetic = to_geodetic_deg(sign.position);
        sign.latitude_deg = geodetic.x();
        sign.longitude_deg = geodetic.y();
        signs_.push_back(sign);
        break;
      }
    }
  }
}

Eigen::Vector2d RoadSignWorld::node(int i, int j) const {
  return {(i - 0.5 * config_.blocks_east) * config_.block_size, (j - 0.5 * config_.blocks_north) * config_.block_size};
}

double RoadSignWorld::road_length() const {
  return config_.block_size * (config_.blocks_east * (config_.blocks_north + 1) + config_.blocks_north * (config_.blocks_east + 1));
}

Eigen::Vector2d RoadSignWorld::to_geodetic_deg(const Eigen::Vector2d& enu) const {
  const double lat0 = config_.centre_latitude_deg * kDegree, h = config_.altitude;
  return {config_.centre_latitude_deg + enu.y() / (meridian_radius_ + h) / kDegree,
          config_.centre_longitude_deg + enu.x() / ((transverse_radius_ + h) * std::cos(lat0)) / kDegree};
}

std::string RoadSignWorld::database_csv() const {
  std::ostringstream out;
  out << "id,class,lat,lon\n" << std::setprecision(12);
  for (const RoadSign& s : signs_) out << s.id << ',' << s.class_label << ',' << s.latitude_deg << ',' << s.longitude_deg << '\n';
  return out.str();
}

}  // namespace locd::sim::road_signs
